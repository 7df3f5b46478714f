#include "tests/simulator/simulation.hpp"

#include <cmath>
#include <istream>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

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

namespace {
constexpr const char* kStateMagic = "hvac-twin-sim state 1";
}  // namespace

void Simulation::save(std::ostream& out) const {
  const auto precision = out.precision(17);  // round trip
  out << kStateMagic << "\nmodel " << unit_.model.type << ' ' << x_.size() << ' ' << u_.size()
      << "\nt " << t_ << "\nx";
  for (double v : x_)
    out << ' ' << v;
  out << "\nu";
  for (double v : u_)
    out << ' ' << v;
  out << "\nnoise " << rng_ << "\nscenario ";
  scenario_->save(out);
  out << '\n';
  out.precision(precision);
}

void Simulation::restore(std::istream& in) {
  std::string line;
  int number = 0;
  // The next line, which must start with `prefix`; the rest of it to parse, and what to say if
  // that fails.
  const auto next = [&](const std::string& prefix, const std::string& expected) {
    ++number;
    const std::string fail = "line " + std::to_string(number) + ": expected " + expected;
    if (!std::getline(in, line)) throw std::runtime_error(fail + ", found the end of the file");
    if (line.compare(0, prefix.size(), prefix) != 0)
      throw std::runtime_error(fail + ", found \"" + line + '"');
    return std::pair{std::istringstream(line.substr(prefix.size())), fail};
  };
  const auto numbers = [&](const char* key, std::vector<double>& to, const char* what) {
    auto [is, fail] = next(std::string(key) + ' ', std::string("\"") + key + "\" and " +
                                                       std::to_string(to.size()) + ' ' + what);
    for (double& v : to)
      if (!(is >> v) || !std::isfinite(v)) throw std::runtime_error(fail);
    if (std::string extra; is >> extra) throw std::runtime_error(fail + ", found more");
  };
  if (auto [is, fail] = next(kStateMagic, std::string("\"") + kStateMagic + '"'); !is.str().empty())
    throw std::runtime_error(fail + ", found \"" + line + '"');
  {
    auto [is, fail] =
        next("model ", "\"model " + unit_.model.type + ' ' + std::to_string(x_.size()) + ' ' +
                           std::to_string(u_.size()) +
                           "\" (this configuration's model, states and inputs)");
    std::string type;
    std::size_t n = 0, m = 0;
    if (!(is >> type >> n >> m) || type != unit_.model.type || n != x_.size() || m != u_.size())
      throw std::runtime_error(fail + ", found \"" + line + '"');
  }
  double t = 0.0;
  {
    auto [is, fail] = next("t ", "\"t\" and the model time in seconds (>= 0)");
    if (!(is >> t) || !(t >= 0.0) || !std::isfinite(t)) throw std::runtime_error(fail);
  }
  std::vector<double> x(x_.size()), u(u_.size());
  numbers("x", x, "state values");
  numbers("u", u, "input values");
  std::mt19937_64 rng;
  if (auto [is, fail] = next("noise ", "\"noise\" and the sensor noise's generator"); !(is >> rng))
    throw std::runtime_error(fail);
  auto [is, fail] = next("scenario ", "\"scenario\" and the scenario's own state");
  // The scenario is the last thing read: nothing has changed if it fails.
  std::ostringstream kept;
  kept.precision(17);
  scenario_->save(kept);
  if (!scenario_->restore(is)) {
    std::istringstream back(kept.str());
    scenario_->restore(back);
    throw std::runtime_error(fail);
  }
  t_ = t;
  x_ = std::move(x);
  u_ = std::move(u);
  rng_ = rng;
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
