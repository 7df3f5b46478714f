// Plain descriptions of a model: its parameters, states, inputs and outputs, with units, ranges
// and defaults. Header-only and dependency-free so configuration validation can check names and
// ranges against a model without linking the model code (the runtime injects a lookup).
//
// Units: every field says its unit in `unit`, using the spellings of config/units.hpp
// ("degC", "K", "W", "kW", "Pa", "kPa", "MPa", "bar", "J/K", "W/K", "1", ...).
#pragma once

#include <cmath>
#include <cstddef>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace hvac_twin::plant {

inline constexpr double kRequired = std::numeric_limits<double>::quiet_NaN();

struct ParameterInfo {
  std::string name;
  std::string unit;
  double default_value = 0.0;
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool integer = false;  // structural parameters such as a cell count
  std::string description;
};

struct StateInfo {
  std::string name;
  std::string unit;
  double min = -std::numeric_limits<double>::infinity();  // physical bounds (constraints)
  double max = std::numeric_limits<double>::infinity();
  double initial = 0.0;        // default initial estimate
  double initial_std = 1.0;    // default initial standard deviation [unit]
  double process_noise = 0.0;  // default random-walk intensity [unit/sqrt(s)]
  double abs_tol = 1e-6;       // integrator absolute tolerance [unit]
  bool augmented = false;      // a slow unknown appended to the physical state (d' = 0)
  std::string description;
  // A "consider" state: uncertain, carried in the covariance, but never moved by an update (a
  // Schmidt-Kalman filter): its uncertainty reaches every estimate it affects, and no
  // measurement pulls it where the data cannot separate it from other states. Estimators honour
  // it; the configuration can change it per state.
  bool consider = false;
  // A closure a commissioning period calibrates: estimated while states the installer knows
  // (the weighed-in charge) are held at their known values, considered afterwards (see
  // daemon/estimation/commissioning.hpp). Implies consider outside commissioning.
  bool calibrate = false;
  // A slow state an initial guess takes from the measured conditions (a zone's temperatures):
  // held there while the model settles (plant_models/core/settling.hpp).
  bool held_while_settling = false;
  // A parameter only a running process reveals (a compressor's efficiency, a coil's boiling
  // coefficient): held (considered) while input `excited_by` is below `excitation_min` (the
  // compressor off), when no measurement carries information on it and the update would move it
  // on the innovations of whatever else the model gets wrong. -1: always estimable.
  int excited_by = -1;
  double excitation_min = 0.0;
  // The unit of the distance within which a model Jacobian evaluated elsewhere is reused
  // (plant::JacobianCache, the integrator's jacobian_reuse_sigma) [unit]; 0: initial_std. A state
  // the Jacobian barely depends on (it enters the model almost linearly) gets a wider one, so
  // that its moves alone do not cost a Jacobian.
  double reuse_scale = 0.0;
  // A property of the unit, not of its operating state (the refrigerant charge, the leak rate,
  // a coil's fouling): kept from a checkpoint too old for the rest of the state to be resumed.
  bool persistent = false;
};

struct SignalInfo {
  std::string name;
  std::string unit;
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  double default_value = kRequired;  // inputs only: NaN means a point must provide it
  std::string description;
  // Outputs only: the model's structural error in this output, what no state estimate removes
  // (closures the model shares with no real unit exactly), as a standard deviation
  // hypot(model_error, model_error_rel * |value|) [unit]. Estimators add it to the sigma they
  // publish; zero for the outputs sensors measure (their representativeness error is the
  // measurement noise's part).
  double model_error = 0.0;
  double model_error_rel = 0.0;
  // Inputs only: the input's counterpart of a state's initial_std for Jacobian reuse. A Jacobian
  // (the model's or the outputs') evaluated at inputs u0 is reused at u while every
  // |u_i - u0_i| <= d * reuse_scale_i, d the same distance in sigmas the states are held to
  // (IntegratorOptions::jacobian_reuse_sigma). 0: any change of the input forces a new one.
  double reuse_scale = 0.0;
};

// A physical constraint  sum_k coeff_k v_k <= bound,  over states (linear in the state, exact)
// or over outputs (nonlinear in the state; the constrained update linearises it at the prior).
// Each state's [min, max] is a constraint as well and is not repeated here.
struct LinearConstraint {
  enum class Over : unsigned char { kStates, kOutputs };
  std::string name;
  Over over = Over::kStates;
  std::vector<std::pair<std::size_t, double>> terms;  // (index, coefficient)
  double bound = 0.0;
  // A condition of operation (output constraints only): the constraint holds only while input
  // `while_input` is at least `while_above` (-1: always). The heat pump's condenser is above its
  // evaporator only while the compressor runs; at rest the pressures equalise through the valve,
  // or, the valve shut, each side's follows its own coldest air.
  int while_input = -1;
  double while_above = 0.0;
};

struct ModelLayout {
  std::vector<StateInfo> states;
  std::vector<SignalInfo> inputs;   // u: actuators and known disturbances, held over a period
  std::vector<SignalInfo> outputs;  // y = h(x, u): what sensors can measure
  std::vector<LinearConstraint> constraints;  // beyond the state bounds

  [[nodiscard]] static std::optional<std::size_t> find(const auto& list, std::string_view name) {
    for (std::size_t i = 0; i < list.size(); ++i)
      if (list[i].name == name) return i;
    return std::nullopt;
  }
  [[nodiscard]] std::optional<std::size_t> state(std::string_view n) const {
    return find(states, n);
  }
  [[nodiscard]] std::optional<std::size_t> input(std::string_view n) const {
    return find(inputs, n);
  }
  [[nodiscard]] std::optional<std::size_t> output(std::string_view n) const {
    return find(outputs, n);
  }
};

using ParameterMap = std::map<std::string, double>;

// What configuration validation needs to know about a model type: its parameters, and the
// layout a full parameter set gives (structural parameters such as a cell count change it).
struct ModelSchema {
  std::string type;
  std::string description;
  std::vector<ParameterInfo> parameters;
  // Called with every parameter present and inside its range; must not throw for such a set.
  std::function<ModelLayout(const ParameterMap&)> layout;
  // A model type whose model comes from a file (an FMU): the schema of the model in `path`, with
  // its own parameters and layout. Throws std::runtime_error saying what is wrong with the file.
  // Empty for the built-in types.
  std::function<ModelSchema(const std::string& path)> from_file;
};

}  // namespace hvac_twin::plant
