// A truth simulation of one configured unit: the plant model (with its own, possibly perturbed,
// parameters) driven by a scenario, and the sensor values it would show on each Modbus point.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <memory>
#include <random>
#include <span>
#include <vector>

#include "config/config.hpp"
#include "config/units.hpp"
#include "plant_models/core/integrator.hpp"
#include "plant_models/core/model.hpp"
#include "tests/simulator/scenario.hpp"

namespace hvac_twin::sim {

struct SimOptions {
  std::uint64_t seed = 1;
  ScenarioOptions scenario;  // its seed is set from `seed`
  double step_s = 5.0;       // model seconds per truth step
  double noise_scale = 1.0;  // sensor noise sigma = noise_scale * the unit's measurement_noise
  plant::ParameterMap parameter_overrides;  // truth parameters differing from the configuration
  // Heat pump: the truth's own cell count and closures (truth_model.hpp) over the configured
  // parameters, before the overrides; false: the configured model as it is.
  bool truth_closures = true;
};

class Simulation {
 public:
  Simulation(const config::UnitConfig& unit, const SimOptions& options);

  // Advances the truth by one step. False if the integrator failed.
  bool step();

  // One engineering value per configured point, in the point's unit: measured points show the
  // true output plus Gaussian noise, input and disturbance points the input applied.
  void point_values(std::span<double> out);

  [[nodiscard]] double time_s() const { return t_; }
  [[nodiscard]] const plant::ContinuousModel& model() const { return *model_; }
  [[nodiscard]] std::span<const double> state() const { return x_; }
  [[nodiscard]] std::span<const double> inputs() const { return u_; }

  // The plant as it stands (model time, states, the inputs of the next interval, the sensor
  // noise's and the scenario's draws and controllers), as text, and back into a Simulation of the
  // same configuration: it then goes on as the saved one would have (to the integrator's
  // round-off: the model's warm starts are not saved). restore() throws std::runtime_error
  // naming the line and what it expected, and changes nothing then.
  void save(std::ostream& out) const;
  void restore(std::istream& in);

  // CSV of the truth: wall_time_ns, t_s, every state, input and output by name (model units).
  void write_csv_header(std::ostream& out) const;
  void write_csv_row(std::ostream& out, std::int64_t wall_time_ns);

 private:
  void drive();

  config::UnitConfig unit_;
  SimOptions options_;
  std::unique_ptr<plant::ContinuousModel> model_;
  std::unique_ptr<plant::Integrator> integrator_;
  std::unique_ptr<Scenario> scenario_;
  std::vector<double> x_, u_, y_;
  std::vector<config::Conversion> to_point_;  // model unit -> point unit, per point
  std::vector<double> noise_sigma_;           // per point [model unit]
  std::vector<long> signal_;                  // per point: output or input index
  std::mt19937_64 rng_;
  double t_ = 0.0;
};

}  // namespace hvac_twin::sim
