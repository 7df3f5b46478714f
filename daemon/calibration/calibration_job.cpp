#include "daemon/calibration/calibration_job.hpp"

#include <algorithm>
#include <cmath>
#include <map>

#include "daemon/calibration/calibration_report.hpp"
#include "daemon/replay/svg_chart.hpp"
#include "daemon/replay/tool_cli.hpp"
#include "plant_models/catalog.hpp"

namespace hvac_twin::calibration {

namespace {
std::string span_h(double start_s, double end_s) {
  char b[64];
  std::snprintf(b, sizeof b, "%.2f-%.2f h", start_s / 3600.0, end_s / 3600.0);
  return b;
}
}  // namespace

CalibrationJob::CalibrationJob(const config::UnitConfig& unit, JobOptions options)
    : unit_(unit), o_(std::move(options)), fit_(o_.fit) {
  // The model with every fitted parameter carried as a state.
  const auto* schema = plant::find_schema(unit.model.type);
  auto params = unit.model.parameters;
  configured_ = plant::create_model(unit.model.type, params);
  if (fit_.empty())
    for (const auto& s : configured_->layout().states)
      if (s.augmented && !s.consider &&
          plant::ModelLayout::find(schema->parameters, "augment_" + s.name))
        fit_.push_back(s.name);
  if (fit_.empty()) throw UsageError("nothing to fit: name parameters with --fit");
  for (std::size_t k = 0; k < fit_.size(); ++k)
    if (std::find(fit_.begin(), fit_.begin() + static_cast<std::ptrdiff_t>(k), fit_[k]) !=
        fit_.begin() + static_cast<std::ptrdiff_t>(k))
      throw UsageError("--fit: " + fit_[k] + " is named twice");
  for (const auto& name : fit_) {
    const std::string augment = "augment_" + name;
    if (!plant::ModelLayout::find(schema->parameters, name) ||
        !plant::ModelLayout::find(schema->parameters, augment))
      throw UsageError("--fit: " + name + " is not a parameter model " + unit.model.type +
                       " can fit");
    params[augment] = 1.0;
  }
  model_ = plant::create_model(unit.model.type, params);
  const auto& layout = model_->layout();
  const auto charge = layout.state("charge");
  if (!charge) throw UsageError("model " + unit.model.type + " has no charge state");
  charge_state_ = *charge;
  const auto& cs = layout.states[charge_state_];
  if (!(o_.charge >= cs.min && o_.charge <= cs.max))
    throw UsageError("--charge: expected kg in [" + replay::fmt(cs.min) + ", " +
                     replay::fmt(cs.max) + "]");
  for (const auto& name : fit_) {
    const auto state = layout.state(name);
    if (!state)
      throw UsageError("--fit: model " + unit.model.type + " carries " + name +
                       " as no state of that name");
    const std::size_t i = *state;
    const auto& s = layout.states[i];
    const auto it = unit.estimator.initial_std.find(name);
    problem_.parameters.push_back(
        {i, s.initial, it != unit.estimator.initial_std.end() ? it->second : s.initial_std, s.min,
         s.max});
  }
  problem_.known = {charge_state_};
  bind_points();
  bind_offsets();
}

void CalibrationJob::bind_points() {
  const auto& layout = model_->layout();
  tolerance_.assign(layout.inputs.size(), 0.0);
  for (std::size_t p = 0; p < unit_.points.size(); ++p) {
    const auto& pt = unit_.points[p];
    const bool measured = pt.role == config::PointRole::kMeasured;
    const auto index = measured ? layout.output(pt.signal) : layout.input(pt.signal);
    const auto& signal = measured ? layout.outputs[*index] : layout.inputs[*index];
    const auto conv = *config::conversion(pt.unit, signal.unit);
    (measured ? outputs_ : inputs_).push_back({p, *index, conv});
    if (measured) {
      problem_.measured.push_back(*index);
      problem_.measured_std.push_back(unit_.estimator.measurement_noise.at(pt.signal));
    } else {
      // 1 % of the point's range: a setpoint held, a temperature within a kelvin.
      tolerance_[*index] = 0.01 * (pt.range_max - pt.range_min) * std::abs(conv.scale);
    }
  }
}

// Offsets to fit: a measured point's, its prior sigma converted to the model's unit.
void CalibrationJob::bind_offsets() {
  problem_.offset_std.assign(problem_.measured.size(), 0.0);
  for (const auto& spec : o_.offsets) {
    const auto eq = spec.find('=');
    const std::string name = spec.substr(0, eq);
    double sigma = 0.0;
    std::size_t k = 0;
    while (k < outputs_.size() && unit_.points[outputs_[k].point].name != name)
      ++k;
    if (eq == std::string::npos || k == outputs_.size() ||
        !replay::parse_amount(spec.substr(eq + 1), true, sigma).empty())
      throw UsageError(
          "--offsets: expected MEASURED_POINT=SIGMA (sigma > 0, in the point's unit), got \"" +
          spec + "\"");
    problem_.offset_std[k] = sigma * std::abs(outputs_[k].to_model.scale);
  }
  for (std::size_t k = 0; k < outputs_.size(); ++k)
    if (problem_.offset_std[k] > 0.0) offset_feed_.push_back(k);
}

CalibrationJob::ReadSummary CalibrationJob::read(replay::CycleReader& reader) {
  const auto& layout = model_->layout();
  WindowFinder finder(tolerance_, layout.outputs.size(), unit_.estimator.period_s, o_.windows);
  recording::RecordedCycle cycle;
  bool new_run = false, first = true;
  std::int64_t t0 = 0;
  ReadSummary summary;
  std::vector<double> u(layout.inputs.size()), y(layout.outputs.size());
  while (reader.next(cycle, new_run)) {
    if (first) t0 = cycle.timestamp_ns;
    first = false;
    ++summary.cycles;
    for (std::size_t i = 0; i < u.size(); ++i)
      u[i] = layout.inputs[i].default_value;  // NaN when a point must feed it
    std::fill(y.begin(), y.end(), std::nan(""));
    auto good = [&](const Feed& f) {
      return cycle.samples[f.point].quality == modbus::PointQuality::kGood;
    };
    for (const auto& f : inputs_)
      u[f.index] = good(f) ? f.to_model.apply(cycle.samples[f.point].value) : std::nan("");
    for (const auto& f : outputs_)
      if (good(f)) y[f.index] = f.to_model.apply(cycle.samples[f.point].value);
    finder.add(static_cast<double>(cycle.timestamp_ns - t0) * 1e-9, u, y);
  }
  const auto windows = finder.finish();
  summary.segments = finder.segments();
  summary.windows = windows.size();
  for (const auto& w : windows) {
    // A parameter only a running process reveals is not fitted on a window where it is unexcited.
    std::string why;
    for (const auto& p : problem_.parameters) {
      const auto& s = layout.states[p.state];
      if (s.excited_by >= 0 && w.u[static_cast<std::size_t>(s.excited_by)] < s.excitation_min)
        why = layout.inputs[static_cast<std::size_t>(s.excited_by)].name + " below " +
              replay::fmt(s.excitation_min) + " (" + s.name + " unexcited)";
    }
    std::vector<double> x(layout.states.size());
    if (why.empty() && !model_->initial_guess(w.u, w.y, x)) why = "no initial guess";
    if (!why.empty()) {
      summary.left_out.push_back(span_h(w.start_s, w.end_s) + ": " + why);
      continue;
    }
    x[charge_state_] = o_.charge;
    problem_.windows.push_back({w.u, w.y, x, w.start_s, w.end_s});
  }
  return summary;
}

est::CalibrationResult CalibrationJob::fit() const {
  return est::calibrate(*model_, problem_);
}

// Offsets in the point's unit: the reading's bias b; the point's configured offset corrects it
// by -b.
std::vector<CalibrationJob::PointOffset> CalibrationJob::point_offsets(
    const est::CalibrationResult& r) const {
  std::vector<PointOffset> out;
  for (std::size_t j = 0; j < offset_feed_.size(); ++j) {
    const auto& f = outputs_[offset_feed_[j]];
    const auto e = static_cast<Eigen::Index>(fit_.size() + j);
    const double scale = std::abs(f.to_model.scale);
    out.push_back({unit_.points[f.point].name, unit_.points[f.point].unit,
                   problem_.offset_std[offset_feed_[j]] / scale, r.value[e] / f.to_model.scale,
                   r.std[e] / scale});
  }
  return out;
}

void CalibrationJob::print(std::FILE* to, const est::CalibrationResult& r, double seconds) const {
  std::fprintf(to, "%-24s %10s %10s %10s %10s\n", "parameter", "prior", "+-", "fitted", "+-");
  for (std::size_t k = 0; k < fit_.size(); ++k)
    std::fprintf(to, "%-24s %10.4f %10.4f %10.4f %10.4f\n", fit_[k].c_str(),
                 problem_.parameters[k].prior, problem_.parameters[k].prior_std,
                 r.value[static_cast<Eigen::Index>(k)], r.std[static_cast<Eigen::Index>(k)]);
  for (const auto& p : point_offsets(r))
    std::fprintf(to, "%-24s %10.4g %10.4g %10.4g %10.4g %s (reading's offset)\n", p.point.c_str(),
                 0.0, p.prior_std, p.value, p.std, p.unit.c_str());
  std::fprintf(to,
               "hvac-twin-calibrate: %zu parameters on %zu windows (%zu residuals): chi-square "
               "%.1f (nominal %.1f), sigma scaled by %.2f; %d iterations, %.1f s\n",
               fit_.size(), problem_.windows.size(), r.residuals, r.chi_square,
               r.chi_square_nominal, std::sqrt(r.birge), r.iterations, seconds);
}

config::CalibrationFile CalibrationJob::file(const est::CalibrationResult& r,
                                             const std::vector<std::string>& inputs) const {
  config::CalibrationFile file;
  file.unit = unit_.id;
  file.model = unit_.model.type;
  nlohmann::ordered_json fit_json = nlohmann::ordered_json::object();
  for (std::size_t k = 0; k < fit_.size(); ++k) {
    const auto e = static_cast<Eigen::Index>(k);
    file.parameters[fit_[k]] = r.value[e];
    // A parameter the unit's filter carries as a state starts from the fit and its sigma; one it
    // does not is a constant at the fitted value.
    if (configured_->layout().state(fit_[k])) file.initial_std[fit_[k]] = r.std[e];
    fit_json[fit_[k]] = {{"prior", problem_.parameters[k].prior},
                         {"prior_sigma", problem_.parameters[k].prior_std},
                         {"value", r.value[e]},
                         {"sigma", r.std[e]}};
  }
  for (const auto& p : point_offsets(r)) {
    file.point_offsets[p.point] = -p.value;
    fit_json["offset of " + p.point + " [" + p.unit + "]"] = {
        {"prior", 0.0}, {"prior_sigma", p.prior_std}, {"value", p.value}, {"sigma", p.std}};
  }
  const auto& layout = model_->layout();
  nlohmann::ordered_json window_json = nlohmann::ordered_json::array();
  for (std::size_t w = 0; w < problem_.windows.size(); ++w) {
    nlohmann::ordered_json residuals = nlohmann::ordered_json::object();
    for (std::size_t k = 0; k < problem_.measured.size(); ++k) {
      const double meas = problem_.windows[w].y[problem_.measured[k]];
      if (!r.windows[w].used || !std::isfinite(meas)) continue;
      const auto e = static_cast<Eigen::Index>(k);
      residuals[layout.outputs[problem_.measured[k]].name] = {{"measured", meas},
                                                              {"nominal", r.windows[w].nominal[e]},
                                                              {"fitted", r.windows[w].fitted[e]}};
    }
    window_json.push_back({{"start_s", problem_.windows[w].start_s},
                           {"end_s", problem_.windows[w].end_s},
                           {"used", r.windows[w].used},
                           {"residuals", residuals}});
    if (!r.windows[w].used) window_json.back()["why"] = r.windows[w].error;
  }
  file.fit = {{"charge_kg", o_.charge},     {"inputs", inputs},
              {"chi_square", r.chi_square}, {"chi_square_nominal", r.chi_square_nominal},
              {"residuals", r.residuals},   {"sigma_scale", std::sqrt(r.birge)},
              {"parameters", fit_json},     {"windows", window_json}};
  return file;
}

void CalibrationJob::report(const config::CalibrationFile& file,
                            const std::string& html_path) const {
  std::map<std::string, std::string> units;
  std::map<std::string, double> sigma;
  const auto& layout = model_->layout();
  for (std::size_t k = 0; k < problem_.measured.size(); ++k) {
    const auto& signal = layout.outputs[problem_.measured[k]];
    units[signal.name] = signal.unit;
    sigma[signal.name] = problem_.measured_std[k];
  }
  write_calibration_report(file.fit, unit_.id, units, sigma, html_path);
}

}  // namespace hvac_twin::calibration
