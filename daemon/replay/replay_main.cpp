// hvac-twin-replay: runs a unit's pipeline (model, filter, constraints, consistency and leak
// monitors: the daemon's code, runtime::UnitPipeline) over the daemon's recording of what the
// unit's filter saw, as fast as the machine allows, and writes what the daemon published as CSV.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "config/load.hpp"
#include "daemon/recording/recording_reader.hpp"
#include "daemon/replay/csv_points.hpp"
#include "daemon/replay/csv_sink.hpp"
#include "daemon/replay/cycle_reader.hpp"
#include "daemon/replay/recording_source.hpp"
#include "daemon/replay/report.hpp"
#include "daemon/replay/smoothing.hpp"
#include "daemon/replay/tool_cli.hpp"
#include "daemon/runtime/logging.hpp"
#include "daemon/runtime/unit_model.hpp"
#include "daemon/runtime/unit_pipeline.hpp"

namespace {

using hvac_twin::recording::RecordedCycle;
using hvac_twin::recording::RecordingReader;

using hvac_twin::replay::kExitNoInput;
using hvac_twin::replay::kExitUsage;
using hvac_twin::replay::text_option;

void usage(std::FILE* to) {
  std::fputs(
      "usage: hvac-twin-replay --config FILE [--unit ID] [--out FILE] [--log-level LEVEL]\n"
      "                        RECORDING...\n"
      "       hvac-twin-replay --config FILE [--unit ID] [--out FILE] [--input-hold-s S]\n"
      "                        POINTS.csv\n"
      "       hvac-twin-replay --config FILE [--unit ID] --export-points POINTS.csv RECORDING...\n"
      "\n"
      "Runs the unit's estimator (the daemon's pipeline) over recorded cycles, as fast as the\n"
      "machine allows, and writes one CSV row per cycle: the virtual sensors with their sigma,\n"
      "every measured point's prediction, innovation and test ratio, and the leak diagnostic.\n"
      "\n"
      "  RECORDING          a recording file (<unit>.<sequence>.htrec), or a directory: the\n"
      "                     unit's files in it, oldest first (the daemon writes them to\n"
      "                     <state_directory>/recordings with runtime.recording_budget_mib)\n"
      "  POINTS.csv         point values with times, exported from a BMS or historian (the\n"
      "                     format: README, \"Replay\"); cycles every period_s over its span\n"
      "  --config FILE      the daemon's configuration (the unit's model, points, estimator)\n"
      "  --unit ID          the unit (default: the first recording's)\n"
      "  --out FILE         the CSV (default: standard output)\n"
      "  --export-points F  write the recording's GOOD point values as a points CSV (times:\n"
      "                     the first cycle's stamp + cycles x period_s); no estimation\n"
      "  --smooth FILE      also write the fixed-interval (RTS) smoothed outputs with their\n"
      "                     sigma to FILE (CSV): after-the-fact estimates from all the data\n"
      "                     (an EKF only). Experimental: on the heat pump it helps some outputs\n"
      "                     and hurts others, and its sigma is too small (README)\n"
      "  --report FILE      also write an HTML report (one file, SVG charts) of the replay;\n"
      "                     needs --out\n"
      "  --input-hold-s S   a CSV input reading stays GOOD this long (default: the point's\n"
      "                     stale_after_s)\n"
      "  --log-level LEVEL  trace|debug|info|warn|error (default warn)\n"
      "\n"
      "Exit status: 0 done, 2 usage, 65 a bad recording, 66 no recording, 78 invalid\n"
      "configuration, 1 any other failure.\n",
      to);
}

struct Options {
  std::string config_path, unit, out_path, export_path, smooth_path, report_path,
      log_level = "warn";
  double input_hold_s = 0.0;
  std::vector<std::string> inputs;
};

// The recordings' GOOD point values as a points CSV (csv_points.hpp), one row per cycle at the
// cycle's model time, so that replaying it runs the same cycles.
int export_points(const std::vector<std::string>& files, const hvac_twin::config::UnitConfig& unit,
                  const std::string& path) {
  std::FILE* out = std::fopen(path.c_str(), "w");
  if (out == nullptr) throw std::runtime_error(path + ": cannot be written");
  std::fprintf(out, "# hvac-twin-replay --export-points: unit %s\ntime", unit.id.c_str());
  for (const auto& p : unit.points)
    std::fprintf(out, ",%s", p.name.c_str());
  std::fputc('\n', out);
  bool first = true;
  std::int64_t t0 = 0;
  std::uint64_t c0 = 0;
  const auto period_ns = static_cast<std::int64_t>(std::llround(unit.estimator.period_s * 1e9));
  RecordedCycle cycle;
  for (const auto& f : files) {
    RecordingReader reader(f);
    hvac_twin::replay::check_points(reader, unit);
    while (reader.next(cycle)) {
      if (first) {
        t0 = cycle.timestamp_ns / 1'000'000'000 * 1'000'000'000;  // whole seconds
        c0 = cycle.cycle;
        first = false;
      }
      const std::int64_t t = t0 + static_cast<std::int64_t>(cycle.cycle - c0) * period_ns;
      std::fprintf(out, "%lld.%09lld", static_cast<long long>(t / 1'000'000'000),
                   static_cast<long long>(t % 1'000'000'000));
      for (const auto& s : cycle.samples) {
        if (s.quality == hvac_twin::modbus::PointQuality::kGood)
          std::fprintf(out, ",%.17g", s.value);
        else
          std::fputc(',', out);
      }
      std::fputc('\n', out);
    }
  }
  if (std::fclose(out) != 0) throw std::runtime_error(path + ": write failed");
  return 0;
}

int replay(const Options& o) {
  auto loaded =
      hvac_twin::config::load_config_file(o.config_path, hvac_twin::runtime::model_catalog());
  if (!loaded.errors.empty()) {
    std::fputs(hvac_twin::config::format_errors(loaded.errors, o.config_path).c_str(), stderr);
    std::fprintf(stderr, "hvac-twin-replay: invalid configuration\n");
    return hvac_twin::config::kExitConfigError;
  }
  hvac_twin::config::Config config = std::move(*loaded.config);
  const std::string unit_id = hvac_twin::replay::pick_unit(o.unit, o.inputs, config);
  std::size_t unit_index = config.units.size();
  for (std::size_t i = 0; i < config.units.size(); ++i)
    if (config.units[i].id == unit_id) unit_index = i;
  if (unit_index == config.units.size()) {
    std::fprintf(stderr, "hvac-twin-replay: %s: no unit \"%s\"\n", o.config_path.c_str(),
                 unit_id.c_str());
    return hvac_twin::config::kExitConfigError;
  }
  // The replay's own: nothing written but the CSV, and no deadline (as fast as it goes).
  config.runtime.recording_budget_mib = 0;
  auto& unit = config.units[unit_index];
  unit.estimator.checkpoint_every_cycles = 0;
  unit.estimator.deadline_s = 1e9;

  const std::vector<std::string> files = hvac_twin::replay::expand_inputs(o.inputs, unit_id);
  if (!o.export_path.empty()) return export_points(files, unit, o.export_path);
  std::FILE* out = stdout;
  if (!o.out_path.empty()) {
    out = std::fopen(o.out_path.c_str(), "w");
    if (out == nullptr) {
      std::fprintf(stderr, "hvac-twin-replay: %s: cannot be written\n", o.out_path.c_str());
      return 1;
    }
  }
  const auto log = hvac_twin::runtime::make_logger(o.log_level);
  // An FMU is unpacked into a private directory, for the pipeline as the daemon's state
  // directory would be (<dir>/fmu/<unit>) and for the layout here (<dir>/layout).
  const hvac_twin::runtime::PrivateDirectory fmu_directory;
  config.state_directory = fmu_directory.path();
  const auto model =
      hvac_twin::runtime::make_unit_model(unit.model, fmu_directory.path() + "/layout").model;
  std::vector<std::string> outputs, points;
  for (const auto& s : model->layout().outputs)
    outputs.push_back(s.name);
  for (const auto& p : unit.points)
    if (p.role == hvac_twin::config::PointRole::kMeasured) points.push_back(p.name);

  hvac_twin::replay::RecordingSource* source = nullptr;
  bool header_written = false;
  const hvac_twin::runtime::UnitIo io{
      .source =
          [&source] {
            auto s = std::make_unique<hvac_twin::replay::RecordingSource>();
            source = s.get();
            return s;
          },
      .sink =
          [&](bool leak) {
            auto s = std::make_unique<hvac_twin::replay::CsvSink>(out, outputs, points, leak);
            if (!header_written) s->write_header();
            header_written = true;
            return s;
          }};

  std::unique_ptr<hvac_twin::replay::Smoothing> smoothing;
  if (!o.smooth_path.empty())
    smoothing = std::make_unique<hvac_twin::replay::Smoothing>(
        model->layout().states.size(), outputs.size(), model->layout().inputs.size());
  std::unique_ptr<hvac_twin::runtime::UnitPipeline> pipeline;
  auto new_pipeline = [&] {
    pipeline.reset();
    pipeline = std::make_unique<hvac_twin::runtime::UnitPipeline>(config, unit_index, io, log,
                                                                  smoothing.get());
    if (smoothing) smoothing->attach(pipeline.get());
  };
  std::uint64_t cycles = 0;
  RecordedCycle cycle;
  const auto started = std::chrono::steady_clock::now();
  hvac_twin::replay::CycleReader reader(files, unit, o.input_hold_s,
                                        [&log](const std::string& w) { log->warn("{}", w); });
  bool new_run = false;
  while (reader.next(cycle, new_run)) {
    if (new_run) new_pipeline();
    source->set(cycle);
    const auto outcome =
        pipeline->run_cycle(hvac_twin::runtime::Tick{.index = cycle.cycle,
                                                     .ticks_since_last = cycle.ticks_since_last,
                                                     .wall_ns = cycle.timestamp_ns});
    if (smoothing) smoothing->end_cycle(cycle.cycle, cycle.timestamp_ns, outcome);
    ++cycles;
  }
  if (smoothing) {
    std::FILE* f = std::fopen(o.smooth_path.c_str(), "w");
    if (f == nullptr) throw std::runtime_error(o.smooth_path + ": cannot be written");
    const auto breaks = smoothing->write(f, *model);
    if (std::fclose(f) != 0) throw std::runtime_error(o.smooth_path + ": write failed");
    log->info("{}: smoothed {} cycles in {} piece(s)", o.smooth_path, cycles, breaks + 1);
  }
  if (out != stdout && std::fclose(out) != 0) {
    std::fprintf(stderr, "hvac-twin-replay: %s: write failed\n", o.out_path.c_str());
    return 1;
  }
  if (!o.report_path.empty()) {
    std::map<std::string, std::string> units;
    for (const auto& s : model->layout().outputs)
      units[s.name] = s.unit;
    for (const auto& p : unit.points)
      units[p.name] = p.unit;
    hvac_twin::replay::write_report(o.out_path, o.smooth_path, unit_id, units, o.report_path);
    log->info("{}: report written", o.report_path);
  }
  const double s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  std::fprintf(stderr,
               "hvac-twin-replay: %llu cycles of unit %s from %zu file(s) in %.1f s (%.0f "
               "cycles/s)%s\n",
               static_cast<unsigned long long>(cycles), unit_id.c_str(), files.size(), s,
               s > 0 ? static_cast<double>(cycles) / s : 0.0,
               reader.torn_tails() > 0 ? ", torn last records skipped" : "");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  const hvac_twin::replay::ToolOption options[] = {text_option("--config", o.config_path),
                                                   text_option("--unit", o.unit),
                                                   text_option("--out", o.out_path),
                                                   text_option("--log-level", o.log_level),
                                                   text_option("--report", o.report_path),
                                                   text_option("--smooth", o.smooth_path),
                                                   text_option("--export-points", o.export_path),
                                                   {"--input-hold-s", [&o](const std::string& v) {
                                                      return hvac_twin::replay::parse_amount(
                                                          v, true, o.input_hold_s);
                                                    }}};
  if (const int rc = hvac_twin::replay::parse_tool_args(argc, argv, "hvac-twin-replay", options,
                                                        o.inputs, usage);
      rc >= 0)
    return rc;
  if (!o.report_path.empty() && o.out_path.empty()) {
    std::fprintf(stderr, "hvac-twin-replay: --report needs --out FILE\n");
    return kExitUsage;
  }
  if (o.config_path.empty() || o.inputs.empty()) {
    usage(stderr);
    return o.config_path.empty() ? kExitUsage : kExitNoInput;
  }
  return hvac_twin::replay::run_tool("hvac-twin-replay", [&o] { return replay(o); });
}
