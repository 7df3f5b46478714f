#include "tests/simulator/simulation.hpp"

#include <cmath>
#include <ostream>
#include <stdexcept>
#include <string>

#include "plant_models/catalog.hpp"
#include "tests/simulator/truth_model.hpp"

namespace hvac_twin::sim {

Simulation::Simulation(const config::UnitConfig& unit, const SimOptions& options)
    : unit_(unit), options_(options), rng_(options.seed) {
  plant::ParameterMap params = unit.model.parameters;
  if (unit.model.type == "heat_pump_r32" && options.truth_closures) params = truth_closures(params);
  for (const auto& [k, v] : options.parameter_overrides)
    params[k] = v;
  model_ = plant::create_model(unit.model.type, params);
  plant::IntegratorOptions io;
  io.rel_tol = 1e-8;
  integrator_ = std::make_unique<plant::Integrator>(*model_, io);
  const plant::ModelLayout& layout = model_->layout();
  ScenarioOptions so = options.scenario;
  so.seed = options.seed;
  scenario_ = make_scenario(unit.model.type, *model_, so);
  x_ = scenario_->initial_state();
  u_.assign(layout.inputs.size(), 0.0);
  for (std::size_t i = 0; i < layout.inputs.size(); ++i)
    if (std::isfinite(layout.inputs[i].default_value)) u_[i] = layout.inputs[i].default_value;
  y_.assign(layout.outputs.size(), 0.0);

  for (const auto& p : unit.points) {
    const bool measured = p.role == config::PointRole::kMeasured;
    const auto index = measured ? layout.output(p.signal) : layout.input(p.signal);
    if (!index) throw std::invalid_argument("point " + p.name + ": unknown signal " + p.signal);
    const std::string& model_unit =
        measured ? layout.outputs[*index].unit : layout.inputs[*index].unit;
    const auto conv = config::conversion(model_unit, p.unit);
    if (!conv) throw std::invalid_argument("point " + p.name + ": unit mismatch");
    to_point_.push_back(*conv);
    signal_.push_back(static_cast<long>(*index));
    double sigma = 0.0;
    if (measured) {
      const auto it = unit.estimator.measurement_noise.find(p.signal);
      if (it != unit.estimator.measurement_noise.end()) sigma = options.noise_scale * it->second;
    }
    noise_sigma_.push_back(sigma);
  }
  drive();
}

void Simulation::drive() {
  // The scenario sees the outputs at the current state with the inputs held so far.
  model_->outputs(x_, u_, y_);
  scenario_->drive(t_, options_.step_s, x_, y_, u_);
}

bool Simulation::step() {
  // u_ was set by the scenario at the start of this interval and is held over it.
  if (!integrator_->step(x_, u_, options_.step_s, {}).ok()) return false;
  t_ += options_.step_s;
  drive();  // inputs of the next interval
  return true;
}

void Simulation::point_values(std::span<double> out) {
  model_->outputs(x_, u_, y_);
  std::normal_distribution<double> g(0.0, 1.0);
  for (std::size_t i = 0; i < unit_.points.size(); ++i) {
    const auto idx = static_cast<std::size_t>(signal_[i]);
    const bool measured = unit_.points[i].role == config::PointRole::kMeasured;
    const double model_value = measured ? y_[idx] + noise_sigma_[i] * g(rng_) : u_[idx];
    out[i] = to_point_[i].apply(model_value);
  }
}

void Simulation::write_csv_header(std::ostream& out) const {
  const plant::ModelLayout& l = model_->layout();
  out << "wall_time_ns,t_s";
  for (const auto& s : l.states)
    out << ",state:" << s.name;
  for (const auto& s : l.inputs)
    out << ",input:" << s.name;
  for (const auto& s : l.outputs)
    out << ",output:" << s.name;
  out << '\n';
}

void Simulation::write_csv_row(std::ostream& out, std::int64_t wall_time_ns) {
  model_->outputs(x_, u_, y_);
  out << wall_time_ns << ',' << t_;
  out.precision(10);
  for (double v : x_)
    out << ',' << v;
  for (double v : u_)
    out << ',' << v;
  for (double v : y_)
    out << ',' << v;
  out << '\n';
}

}  // namespace hvac_twin::sim
