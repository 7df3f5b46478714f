// What drives a truth simulation: the initial state, the inputs (actuators, weather) and the
// disturbance states over time. Each model type has its own.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <memory>
#include <span>
#include <string_view>
#include <vector>

#include "plant_models/core/model.hpp"

namespace hvac_twin::sim {

struct ScenarioOptions {
  std::uint64_t seed = 1;
  double leak_g_per_h = 0.0;  // refrigerant leak rate from leak_start_s on (heat pump)
  double leak_start_s = 0.0;
  double leak_end_s = 1e30;  // and until then (a sudden loss: a burst hose, a service valve)
  double charge_kg = 0.0;    // truth refrigerant charge (heat pump); 0: the nameplate charge
  // Heat pump: a commissioning run instead of the day's control loops: the engineer holds six
  // operating points (speed, valve opening, fans) for 45 min each, in turn.
  bool commissioning = false;
};

class Scenario {
 public:
  virtual ~Scenario() = default;
  // The truth's state at t = 0 (and the scenario's controllers initialised to it).
  virtual std::vector<double> initial_state() = 0;
  // Called before the truth advances over [t, t + dt] (model seconds since the start), with the
  // outputs y at the current state: sets the inputs u (model units) and may overwrite
  // disturbance states of x (internal gains, a leak).
  virtual void drive(double t, double dt, std::span<double> x, std::span<const double> y,
                     std::span<double> u) = 0;
  // What the scenario carries from one drive() to the next (its random draws, the controllers'
  // integrators), as one line of text without its end, and back: a restarted simulator
  // continues the same plant (Simulation::save). restore() returns false on text it did not
  // write.
  virtual void save(std::ostream& out) const = 0;
  virtual bool restore(std::istream& in) = 0;
};

// The scenario for the model's type; throws std::invalid_argument for a type without one.
std::unique_ptr<Scenario> make_scenario(std::string_view model_type,
                                        const plant::ContinuousModel& model,
                                        const ScenarioOptions& options);

}  // namespace hvac_twin::sim
