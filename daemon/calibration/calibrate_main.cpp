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
#include "daemon/calibration/calibration_report.hpp"
#include "daemon/calibration/steady_windows.hpp"
#include "daemon/estimation/batch_calibration.hpp"
#include "daemon/replay/cycle_reader.hpp"
#include "daemon/replay/tool_cli.hpp"
#include "daemon/runtime/logging.hpp"
#include "plant_models/catalog.hpp"

namespace {

namespace cal = hvac_twin::calibration;
namespace est = hvac_twin::est;

using hvac_twin::replay::kExitDataError;
using hvac_twin::replay::kExitNoInput;
using hvac_twin::replay::kExitUsage;
using hvac_twin::replay::text_option;

void usage(std::FILE* to) {
  std::fputs(
      "usage: hvac-twin-calibrate --config FILE --charge KG [--unit ID] [--fit P1,P2,...]\n"
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
  std::vector<std::string> fit, inputs;
  double charge = std::nan(""), input_hold_s = 0.0;
  cal::WindowOptions windows;
};

// A point feeding a model input or output, in the model's unit.
struct Feed {
  std::size_t point, index;
  hvac_twin::config::Conversion to_model;
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

  // The model with every fitted parameter carried as a state.
  const auto* schema = hvac_twin::plant::find_schema(unit->model.type);
  auto params = unit->model.parameters;
  const auto configured = hvac_twin::plant::create_model(unit->model.type, params);
  std::vector<std::string> fit = o.fit;
  if (fit.empty())
    for (const auto& s : configured->layout().states)
      if (s.augmented && !s.consider &&
          hvac_twin::plant::ModelLayout::find(schema->parameters, "augment_" + s.name))
        fit.push_back(s.name);
  for (const auto& name : fit) {
    const std::string augment = "augment_" + name;
    if (!hvac_twin::plant::ModelLayout::find(schema->parameters, name) ||
        !hvac_twin::plant::ModelLayout::find(schema->parameters, augment)) {
      std::fprintf(stderr, "hvac-twin-calibrate: --fit: %s is not a parameter model %s can fit\n",
                   name.c_str(), unit->model.type.c_str());
      return kExitUsage;
    }
    params[augment] = 1.0;
  }
  if (fit.empty()) {
    std::fprintf(stderr, "hvac-twin-calibrate: nothing to fit: name parameters with --fit\n");
    return kExitUsage;
  }
  const auto model = hvac_twin::plant::create_model(unit->model.type, params);
  const auto& layout = model->layout();
  const auto charge_state = layout.state("charge");
  if (!charge_state) {
    std::fprintf(stderr, "hvac-twin-calibrate: model %s has no charge state\n",
                 unit->model.type.c_str());
    return kExitUsage;
  }
  if (!(o.charge >= layout.states[*charge_state].min &&
        o.charge <= layout.states[*charge_state].max)) {
    std::fprintf(stderr, "hvac-twin-calibrate: --charge: expected kg in [%g, %g]\n",
                 layout.states[*charge_state].min, layout.states[*charge_state].max);
    return kExitUsage;
  }

  est::CalibrationProblem problem;
  for (const auto& name : fit) {
    const std::size_t i = *layout.state(name);
    const auto& s = layout.states[i];
    const auto std_it = unit->estimator.initial_std.find(name);
    problem.parameters.push_back(
        {i, s.initial, std_it != unit->estimator.initial_std.end() ? std_it->second : s.initial_std,
         s.min, s.max});
  }
  problem.known = {*charge_state};

  // Points to model inputs and outputs.
  std::vector<Feed> inputs, outputs;
  std::vector<double> tolerance(layout.inputs.size(), 0.0);
  for (std::size_t p = 0; p < unit->points.size(); ++p) {
    const auto& pt = unit->points[p];
    const bool measured = pt.role == hvac_twin::config::PointRole::kMeasured;
    const auto index = measured ? layout.output(pt.signal) : layout.input(pt.signal);
    const auto& signal = measured ? layout.outputs[*index] : layout.inputs[*index];
    const auto conv = *hvac_twin::config::conversion(pt.unit, signal.unit);
    (measured ? outputs : inputs).push_back({p, *index, conv});
    if (measured) {
      problem.measured.push_back(*index);
      problem.measured_std.push_back(unit->estimator.measurement_noise.at(pt.signal));
    } else {
      // 1 % of the point's range: a setpoint held, a temperature within a kelvin.
      tolerance[*index] = 0.01 * (pt.range_max - pt.range_min) * std::abs(conv.scale);
    }
  }

  const auto started = std::chrono::steady_clock::now();
  const auto files = hvac_twin::replay::expand_inputs(o.inputs, unit_id);
  hvac_twin::replay::CycleReader reader(files, *unit, o.input_hold_s,
                                        [&log](const std::string& w) { log->warn("{}", w); });
  cal::WindowFinder finder(tolerance, layout.outputs.size(), unit->estimator.period_s, o.windows);
  hvac_twin::recording::RecordedCycle cycle;
  bool new_run = false, first = true;
  std::int64_t t0 = 0;
  std::size_t cycles = 0;
  std::vector<double> u(layout.inputs.size()), y(layout.outputs.size());
  while (reader.next(cycle, new_run)) {
    if (first) t0 = cycle.timestamp_ns;
    first = false;
    ++cycles;
    for (std::size_t i = 0; i < u.size(); ++i)
      u[i] = layout.inputs[i].default_value;  // NaN when a point must feed it
    std::fill(y.begin(), y.end(), std::nan(""));
    auto good = [&](const Feed& f) {
      return cycle.samples[f.point].quality == hvac_twin::modbus::PointQuality::kGood;
    };
    for (const auto& f : inputs)
      u[f.index] = good(f) ? f.to_model.apply(cycle.samples[f.point].value) : std::nan("");
    for (const auto& f : outputs)
      if (good(f)) y[f.index] = f.to_model.apply(cycle.samples[f.point].value);
    finder.add(static_cast<double>(cycle.timestamp_ns - t0) * 1e-9, u, y);
  }
  const auto windows = finder.finish();
  log->info("{} cycles from {} file(s): {} steady segment(s), {} window(s) of at least {} s",
            cycles, reader.files(), finder.segments(), windows.size(), o.windows.min_window_s);

  std::vector<std::string> skipped;
  for (const auto& w : windows) {
    // A parameter only a running process reveals is not fitted on a window where it is unexcited.
    std::string why;
    for (const auto& p : problem.parameters) {
      const auto& s = layout.states[p.state];
      if (s.excited_by >= 0 && w.u[static_cast<std::size_t>(s.excited_by)] < s.excitation_min)
        why = layout.inputs[static_cast<std::size_t>(s.excited_by)].name + " below " +
              std::to_string(s.excitation_min) + " (" + s.name + " unexcited)";
    }
    std::vector<double> x(layout.states.size());
    if (why.empty() && !model->initial_guess(w.u, w.y, x)) why = "no initial guess";
    if (!why.empty()) {
      log->info("window {:.0f}-{:.0f} s left out: {}", w.start_s, w.end_s, why);
      continue;
    }
    x[*charge_state] = o.charge;
    problem.windows.push_back({w.u, w.y, x, w.start_s, w.end_s});
  }
  if (problem.windows.empty()) {
    std::fprintf(stderr,
                 "hvac-twin-calibrate: no steady window with the unit running (%zu cycles, %zu "
                 "segments): hold each operating point for more than --settle-s + "
                 "--min-window-s (%g s)\n",
                 cycles, finder.segments(), o.windows.settle_s + o.windows.min_window_s);
    return kExitDataError;
  }
  const auto result = est::calibrate(*model, problem);
  for (std::size_t w = 0; w < result.windows.size(); ++w)
    if (!result.windows[w].used)
      log->warn("window {:.0f}-{:.0f} s left out: {}", problem.windows[w].start_s,
                problem.windows[w].end_s, result.windows[w].error);
  if (!result.ok) {
    std::fprintf(stderr, "hvac-twin-calibrate: the fit failed: %s\n", result.error.c_str());
    return 1;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  std::fprintf(stderr, "%-24s %10s %10s %10s %10s\n", "parameter", "prior", "+-", "fitted", "+-");
  for (std::size_t k = 0; k < fit.size(); ++k)
    std::fprintf(stderr, "%-24s %10.4f %10.4f %10.4f %10.4f\n", fit[k].c_str(),
                 problem.parameters[k].prior, problem.parameters[k].prior_std,
                 result.value[static_cast<Eigen::Index>(k)],
                 result.std[static_cast<Eigen::Index>(k)]);
  std::fprintf(stderr,
               "hvac-twin-calibrate: %zu parameters on %zu windows (%zu residuals): chi-square "
               "%.1f (nominal %.1f), sigma scaled by %.2f; %d iterations, %.1f s\n",
               fit.size(), problem.windows.size(), result.residuals, result.chi_square,
               result.chi_square_nominal, std::sqrt(result.birge), result.iterations, seconds);

  hvac_twin::config::CalibrationFile file;
  file.unit = unit_id;
  file.model = unit->model.type;
  for (std::size_t k = 0; k < fit.size(); ++k) {
    const auto e = static_cast<Eigen::Index>(k);
    file.parameters[fit[k]] = result.value[e];
    // A parameter the unit's filter carries as a state starts from the fit and its sigma; one it
    // does not is a constant at the fitted value.
    if (configured->layout().state(fit[k])) file.initial_std[fit[k]] = result.std[e];
  }
  nlohmann::ordered_json fit_json = nlohmann::ordered_json::object();
  for (std::size_t k = 0; k < fit.size(); ++k) {
    const auto e = static_cast<Eigen::Index>(k);
    fit_json[fit[k]] = {{"prior", problem.parameters[k].prior},
                        {"prior_sigma", problem.parameters[k].prior_std},
                        {"value", result.value[e]},
                        {"sigma", result.std[e]}};
  }
  nlohmann::ordered_json window_json = nlohmann::ordered_json::array();
  for (std::size_t w = 0; w < problem.windows.size(); ++w) {
    nlohmann::ordered_json residuals = nlohmann::ordered_json::object();
    for (std::size_t k = 0; k < problem.measured.size(); ++k) {
      const double meas = problem.windows[w].y[problem.measured[k]];
      if (!result.windows[w].used || !std::isfinite(meas)) continue;
      const auto e = static_cast<Eigen::Index>(k);
      residuals[layout.outputs[problem.measured[k]].name] = {
          {"measured", meas},
          {"nominal", result.windows[w].nominal[e]},
          {"fitted", result.windows[w].fitted[e]}};
    }
    window_json.push_back({{"start_s", problem.windows[w].start_s},
                           {"end_s", problem.windows[w].end_s},
                           {"used", result.windows[w].used},
                           {"residuals", residuals}});
    if (!result.windows[w].used) window_json.back()["why"] = result.windows[w].error;
  }
  file.fit = {{"charge_kg", o.charge},           {"inputs", o.inputs},
              {"chi_square", result.chi_square}, {"chi_square_nominal", result.chi_square_nominal},
              {"residuals", result.residuals},   {"sigma_scale", std::sqrt(result.birge)},
              {"parameters", fit_json},          {"windows", window_json}};
  if (!o.report_path.empty()) {
    std::map<std::string, std::string> units;
    std::map<std::string, double> sigma;
    for (std::size_t k = 0; k < problem.measured.size(); ++k) {
      const auto& signal = layout.outputs[problem.measured[k]];
      units[signal.name] = signal.unit;
      sigma[signal.name] = problem.measured_std[k];
    }
    cal::write_calibration_report(file.fit, unit_id, units, sigma, o.report_path);
  }
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
         o.fit = split_list(v);
         return std::string();
       }},
      {"--charge", amount(o.charge, true)},
      {"--settle-s", amount(o.windows.settle_s, false)},
      {"--min-window-s", amount(o.windows.min_window_s, false)},
      {"--input-hold-s", amount(o.input_hold_s, true)}};
  if (const int rc = hvac_twin::replay::parse_tool_args(argc, argv, "hvac-twin-calibrate", options,
                                                        o.inputs, usage);
      rc >= 0)
    return rc;
  if (o.config_path.empty() || o.inputs.empty() || std::isnan(o.charge)) {
    if (!o.config_path.empty() && !o.inputs.empty())
      std::fprintf(stderr, "hvac-twin-calibrate: --charge KG is required\n\n");
    usage(stderr);
    return o.config_path.empty() || std::isnan(o.charge) ? kExitUsage : kExitNoInput;
  }
  return hvac_twin::replay::run_tool("hvac-twin-calibrate", [&o] { return run(o); });
}
