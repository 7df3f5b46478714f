// What drives a truth simulation: inputs (actuators, weather) and disturbance states over time.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string_view>

#include "plant_models/core/model_info.hpp"

namespace hvac_twin::sim {

class Scenario {
 public:
  virtual ~Scenario() = default;
  // Called before the truth advances over [t, t + dt] (model seconds since the start): sets the
  // inputs u (model units) and may overwrite disturbance states of x (e.g. internal gains).
  virtual void drive(double t, double dt, std::span<double> x, std::span<double> u) = 0;
};

// The scenario for a model type; throws std::invalid_argument for a type without one.
std::unique_ptr<Scenario> make_scenario(std::string_view model_type,
                                        const plant::ModelLayout& layout, std::uint64_t seed);

}  // namespace hvac_twin::sim
