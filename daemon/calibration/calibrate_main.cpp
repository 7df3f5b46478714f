// hvac-twin-calibrate: fits a unit model's uncertain parameters to the steady operating windows
// of a commissioning period with the charge known (daemon/estimation/batch_calibration.hpp), from
// the daemon's recordings or a points CSV, and writes a calibration file the unit's
// configuration includes ("calibration": "<file>", config/README.md).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <string_view>
#include <vector>

#include "config/calibration_file.hpp"
#include "config/load.hpp"
#include "config/units.hpp"
#include "daemon/calibration/calibration_job.hpp"
#include "daemon/replay/cycle_reader.hpp"
#include "daemon/replay/tool_cli.hpp"
#include "daemon/runtime/logging.hpp"
#include "plant_models/catalog.hpp"

namespace {

namespace cal = hvac_twin::calibration;

using hvac_twin::replay::kExitDataError;
using hvac_twin::replay::kExitNoInput;
using hvac_twin::replay::kExitUsage;
using hvac_twin::replay::text_option;

void usage(std::FILE* to) {
  std::fputs(
      "usage: hvac-twin-calibrate --config FILE --charge KG [--unit ID] [--fit P1,P2,...]\n"
      "                           [--offsets POINT=SIGMA,...]\n"
      "                           [--out FILE] [--report FILE] [--settle-s S] [--min-window-s S]\n"
      "                           [--input-hold-s S] [--log-level LEVEL] INPUT...\n"
      "\n"
      "Fits the unit model's uncertain parameters (its factors: coil UA, compressor flow and\n"
      "efficiency, valve, two-phase closures) to the steady operating windows of a\n"
      "commissioning period in which the refrigerant charge is known (weighed in), by a\n"
      "Levenberg-Marquardt fit with exact derivatives, and writes the parameters with their\n"
      "sigma as a calibration file for the unit's configuration (\"calibration\": FILE).\n"
      "\n"
      "  INPUT             the daemon's recordings (files or a directory) or one points CSV,\n"
      "                    as hvac-twin-replay reads them\n"
      "  --config FILE     the daemon's configuration (the unit's model, points, noise)\n"
      "  --charge KG       the refrigerant charge during the period [kg]\n"
      "  --unit ID         the unit (default: the first recording's)\n"
      "  --fit LIST        the parameters to fit (default: every factor the unit's model\n"
      "                    carries as a state, but those it only considers)\n"
      "  --offsets LIST    also fit these measured points' offsets, each POINT=SIGMA with\n"
      "                    its prior sigma in the point's unit (e.g. outdoor_coil_in_temp=0.5)\n"
      "  --out FILE        the calibration file (default: standard output)\n"
      "  --report FILE     also write an HTML report (one file, SVG charts): the parameters\n"
      "                    against their prior, each point's residuals window by window\n"
      "  --settle-s S      after an input changes, wait this long before a window (900)\n"
      "  --min-window-s S  the shortest steady window used (300)\n"
      "  --input-hold-s S  a CSV input reading stays GOOD this long (as hvac-twin-replay)\n"
      "  --log-level LEVEL trace|debug|info|warn|error (default info)\n"
      "\n"
      "Exit status: 0 fitted, 1 the fit failed, 2 usage, 65 bad input data, 66 no input,\n"
      "78 invalid configuration.\n",
      to);
}

struct Options {
  std::string config_path, unit, out_path, report_path, log_level = "info";
  std::vector<std::string> inputs;
  double input_hold_s = 0.0;
  cal::JobOptions job{.charge = std::nan("")};
};

std::vector<std::string> split_list(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

int run(const Options& o) {
  auto loaded =
      hvac_twin::config::load_config_file(o.config_path, hvac_twin::plant::model_schemas());
  if (!loaded.errors.empty()) {
    std::fputs(hvac_twin::config::format_errors(loaded.errors, o.config_path).c_str(), stderr);
    std::fprintf(stderr, "hvac-twin-calibrate: invalid configuration\n");
    return hvac_twin::config::kExitConfigError;
  }
  const auto& config = *loaded.config;
  const std::string unit_id = hvac_twin::replay::pick_unit(o.unit, o.inputs, config);
  const hvac_twin::config::UnitConfig* unit = nullptr;
  for (const auto& u : config.units)
    if (u.id == unit_id) unit = &u;
  if (unit == nullptr) {
    std::fprintf(stderr, "hvac-twin-calibrate: %s: no unit \"%s\"\n", o.config_path.c_str(),
                 unit_id.c_str());
    return hvac_twin::config::kExitConfigError;
  }
  const auto log = hvac_twin::runtime::make_logger(o.log_level);
  if (!unit->calibration.empty())
    log->warn(
        "unit {} includes the calibration {}: it is the fit's prior (its values and sigma); "
        "for a fit from the nominal values, calibrate with a configuration without it",
        unit_id, unit->calibration);
  std::unique_ptr<cal::CalibrationJob> job;
  try {
    job = std::make_unique<cal::CalibrationJob>(*unit, o.job);
  } catch (const cal::UsageError& e) {
    std::fprintf(stderr, "hvac-twin-calibrate: %s\n", e.what());
    return kExitUsage;
  }

  const auto started = std::chrono::steady_clock::now();
  hvac_twin::replay::CycleReader reader(hvac_twin::replay::expand_inputs(o.inputs, unit_id), *unit,
                                        o.input_hold_s,
                                        [&log](const std::string& w) { log->warn("{}", w); });
  const auto read = job->read(reader);
  log->info("{} cycles from {} file(s): {} steady segment(s), {} window(s) of at least {} s",
            read.cycles, reader.files(), read.segments, read.windows, o.job.windows.min_window_s);
  for (const auto& why : read.left_out)
    log->info("window {} left out", why);
  if (job->windows() == 0) {
    std::fprintf(stderr,
                 "hvac-twin-calibrate: no steady window with the unit running (%zu cycles, %zu "
                 "segments): hold each operating point for more than --settle-s + "
                 "--min-window-s (%g s)\n",
                 read.cycles, read.segments, o.job.windows.settle_s + o.job.windows.min_window_s);
    return kExitDataError;
  }
  const auto result = job->fit();
  for (const auto& w : result.windows)
    if (!w.used) log->warn("a window left out of the fit: {}", w.error);
  if (!result.ok) {
    std::fprintf(stderr, "hvac-twin-calibrate: the fit failed: %s\n", result.error.c_str());
    return 1;
  }
  job->print(stderr, result,
             std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count());
  const auto file = job->file(result, o.inputs);
  if (!o.report_path.empty()) job->report(file, o.report_path);
  const std::string text = hvac_twin::config::write_calibration(file);
  if (o.out_path.empty()) {
    std::fputs(text.c_str(), stdout);
    return 0;
  }
  std::ofstream out(o.out_path);
  out << text;
  out.close();
  if (!out) {
    std::fprintf(stderr, "hvac-twin-calibrate: %s: cannot be written\n", o.out_path.c_str());
    return 1;
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  auto amount = [](double& field, bool positive) {
    return [&field, positive](const std::string& v) {
      return hvac_twin::replay::parse_amount(v, positive, field);
    };
  };
  const hvac_twin::replay::ToolOption options[] = {
      text_option("--config", o.config_path),
      text_option("--unit", o.unit),
      text_option("--out", o.out_path),
      text_option("--report", o.report_path),
      text_option("--log-level", o.log_level),
      {"--fit",
       [&o](const std::string& v) {
         o.job.fit = split_list(v);
         return std::string();
       }},
      {"--charge", amount(o.job.charge, true)},
      {"--offsets",
       [&o](const std::string& v) {
         o.job.offsets = split_list(v);
         return std::string();
       }},
      {"--settle-s", amount(o.job.windows.settle_s, false)},
      {"--min-window-s", amount(o.job.windows.min_window_s, false)},
      {"--input-hold-s", amount(o.input_hold_s, true)}};
  if (const int rc = hvac_twin::replay::parse_tool_args(argc, argv, "hvac-twin-calibrate", options,
                                                        o.inputs, usage);
      rc >= 0)
    return rc;
  if (o.config_path.empty() || o.inputs.empty() || std::isnan(o.job.charge)) {
    if (!o.config_path.empty() && !o.inputs.empty())
      std::fprintf(stderr, "hvac-twin-calibrate: --charge KG is required\n\n");
    usage(stderr);
    return o.config_path.empty() || std::isnan(o.job.charge) ? kExitUsage : kExitNoInput;
  }
  return hvac_twin::replay::run_tool("hvac-twin-calibrate", [&o] { return run(o); });
}
