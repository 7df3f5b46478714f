// hvac-twin-replay: runs a unit's pipeline (model, filter, constraints, consistency and leak
// monitors: the daemon's code, runtime::UnitPipeline) over the daemon's recording of what the
// unit's filter saw, as fast as the machine allows, and writes what the daemon published as CSV.
#include <chrono>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "config/load.hpp"
#include "daemon/recording/recording_reader.hpp"
#include "daemon/replay/csv_sink.hpp"
#include "daemon/replay/recording_source.hpp"
#include "daemon/runtime/logging.hpp"
#include "daemon/runtime/unit_pipeline.hpp"
#include "plant_models/catalog.hpp"

namespace {

using hvac_twin::recording::RecordedCycle;
using hvac_twin::recording::RecordingError;
using hvac_twin::recording::RecordingReader;

constexpr int kExitUsage = 2;
constexpr int kExitDataError = 65;  // sysexits EX_DATAERR: a bad recording
constexpr int kExitNoInput = 66;    // EX_NOINPUT

void usage(std::FILE* to) {
  std::fputs(
      "usage: hvac-twin-replay --config FILE [--unit ID] [--out FILE] [--log-level LEVEL]\n"
      "                        RECORDING...\n"
      "\n"
      "Runs the unit's estimator (the daemon's pipeline) over recorded cycles, as fast as the\n"
      "machine allows, and writes one CSV row per cycle: the virtual sensors with their sigma,\n"
      "every measured point's prediction, innovation and test ratio, and the leak diagnostic.\n"
      "\n"
      "  RECORDING          a recording file (<unit>.<sequence>.htrec), or a directory: the\n"
      "                     unit's files in it, oldest first (the daemon writes them to\n"
      "                     <state_directory>/recordings with runtime.recording_budget_mib)\n"
      "  --config FILE      the daemon's configuration (the unit's model, points, estimator)\n"
      "  --unit ID          the unit (default: the first recording's)\n"
      "  --out FILE         the CSV (default: standard output)\n"
      "  --log-level LEVEL  trace|debug|info|warn|error (default warn)\n"
      "\n"
      "Exit status: 0 done, 2 usage, 65 a bad recording, 66 no recording, 78 invalid\n"
      "configuration, 1 any other failure.\n",
      to);
}

// The recording's points are the configured unit's: same names, order, units and roles.
void check_points(const RecordingReader& r, const hvac_twin::config::UnitConfig& unit) {
  const auto& points = r.header().points;
  if (points.size() != unit.points.size())
    throw RecordingError(r.path() + ": " + std::to_string(points.size()) +
                         " points recorded, the configuration's unit " + unit.id + " has " +
                         std::to_string(unit.points.size()));
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto& c = unit.points[i];
    if (points[i].name != c.name || points[i].unit != c.unit)
      throw RecordingError(r.path() + ": point " + std::to_string(i + 1) + " recorded as " +
                           points[i].name + " [" + points[i].unit + "], the configuration has " +
                           c.name + " [" + c.unit + "]");
  }
}

struct Options {
  std::string config_path, unit, out_path, log_level = "warn";
  std::vector<std::string> inputs;
};

// The files to replay, in order: files as given, directories expanded to the unit's files.
std::vector<std::string> expand(const Options& o, const std::string& unit) {
  std::vector<std::string> files;
  for (const auto& in : o.inputs) {
    std::error_code ec;
    if (!std::filesystem::is_directory(in, ec)) {
      files.push_back(in);
      continue;
    }
    const auto found = hvac_twin::recording::unit_recordings(in, unit);
    if (found.empty()) throw RecordingError(in + ": no recording of unit " + unit);
    files.insert(files.end(), found.begin(), found.end());
  }
  return files;
}

// The unit of the replay: --unit, or the first file's (a directory: the configuration's only
// unit).
std::string pick_unit(const Options& o, const hvac_twin::config::Config& config) {
  if (!o.unit.empty()) return o.unit;
  std::error_code ec;
  if (!std::filesystem::is_directory(o.inputs.front(), ec))
    return RecordingReader(o.inputs.front()).header().unit;
  if (config.units.size() == 1) return config.units.front().id;
  throw RecordingError(o.inputs.front() + ": a directory and several units: name one with --unit");
}

int replay(const Options& o) {
  auto loaded =
      hvac_twin::config::load_config_file(o.config_path, hvac_twin::plant::model_schemas());
  if (!loaded.errors.empty()) {
    std::fputs(hvac_twin::config::format_errors(loaded.errors, o.config_path).c_str(), stderr);
    std::fprintf(stderr, "hvac-twin-replay: invalid configuration\n");
    return hvac_twin::config::kExitConfigError;
  }
  hvac_twin::config::Config config = std::move(*loaded.config);
  const std::string unit_id = pick_unit(o, config);
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

  const std::vector<std::string> files = expand(o, unit_id);
  std::FILE* out = stdout;
  if (!o.out_path.empty()) {
    out = std::fopen(o.out_path.c_str(), "w");
    if (out == nullptr) {
      std::fprintf(stderr, "hvac-twin-replay: %s: cannot be written\n", o.out_path.c_str());
      return 1;
    }
  }
  const auto log = hvac_twin::runtime::make_logger(o.log_level);
  const auto model = hvac_twin::plant::create_model(unit.model.type, unit.model.parameters);
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

  std::unique_ptr<hvac_twin::runtime::UnitPipeline> pipeline;
  std::int64_t run = 0;
  std::uint64_t cycles = 0, torn = 0;
  RecordedCycle cycle;
  const auto started = std::chrono::steady_clock::now();
  for (const auto& path : files) {
    RecordingReader reader(path);
    check_points(reader, unit);
    if (reader.header().unit != unit_id)
      throw RecordingError(path + ": a recording of unit " + reader.header().unit + ", not " +
                           unit_id);
    if (!pipeline || reader.header().run_ns != run) {
      // A recording from another run of the daemon: its estimator started again too.
      if (pipeline)
        log->warn(
            "{}: recorded by another run of the daemon; the estimator starts again from the "
            "measured conditions (a daemon that resumed from a checkpoint did not)",
            path);
      pipeline.reset();
      pipeline = std::make_unique<hvac_twin::runtime::UnitPipeline>(config, unit_index, io, log);
      run = reader.header().run_ns;
    }
    while (reader.next(cycle)) {
      source->set(cycle);
      pipeline->run_cycle(hvac_twin::runtime::Tick{.index = cycle.cycle,
                                                   .ticks_since_last = cycle.ticks_since_last,
                                                   .wall_ns = cycle.timestamp_ns});
      ++cycles;
    }
    if (reader.torn_tail()) {
      ++torn;
      log->warn("{}: the last record (at byte {}) is torn (a write a crash interrupted): skipped",
                path, reader.torn_offset());
    }
  }
  if (out != stdout && std::fclose(out) != 0) {
    std::fprintf(stderr, "hvac-twin-replay: %s: write failed\n", o.out_path.c_str());
    return 1;
  }
  const double s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  std::fprintf(stderr,
               "hvac-twin-replay: %llu cycles of unit %s from %zu file(s) in %.1f s (%.0f "
               "cycles/s)%s\n",
               static_cast<unsigned long long>(cycles), unit_id.c_str(), files.size(), s,
               s > 0 ? static_cast<double>(cycles) / s : 0.0,
               torn > 0 ? ", torn last records skipped" : "");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--help" || arg == "-h") {
      usage(stdout);
      return 0;
    } else if (arg == "--config" && has_value) {
      o.config_path = argv[++i];
    } else if (arg == "--unit" && has_value) {
      o.unit = argv[++i];
    } else if (arg == "--out" && has_value) {
      o.out_path = argv[++i];
    } else if (arg == "--log-level" && has_value) {
      o.log_level = argv[++i];
    } else if (!arg.starts_with("--")) {
      o.inputs.emplace_back(arg);
    } else {
      std::fprintf(stderr, "hvac-twin-replay: unknown or incomplete option \"%s\"\n\n", argv[i]);
      usage(stderr);
      return kExitUsage;
    }
  }
  if (o.config_path.empty() || o.inputs.empty()) {
    usage(stderr);
    return o.config_path.empty() ? kExitUsage : kExitNoInput;
  }
  try {
    return replay(o);
  } catch (const RecordingError& e) {
    std::fprintf(stderr, "hvac-twin-replay: %s\n", e.what());
    return kExitDataError;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hvac-twin-replay: %s\n", e.what());
    return 1;
  }
}
