// Small models for estimator tests, written like plant models (templated on the scalar).
#pragma once

#include <cmath>
#include <span>
#include <string>

#include "plant_models/core/model.hpp"
#include "plant_models/core/model_info.hpp"

namespace hvac_twin::test {

// x' = 0 (a random walk once the filter adds noise), y = x.
struct RandomWalk {
  plant::ModelLayout layout() const {
    plant::ModelLayout l;
    l.states.push_back(plant::StateInfo{.name = "x", .unit = "1", .abs_tol = 1e-10});
    l.outputs.push_back(plant::SignalInfo{.name = "y", .unit = "1"});
    return l;
  }
  template <class S>
  int rhs(std::span<const S>, std::span<const double>, std::span<S> f) const {
    f[0] = S(0.0);
    return plant::kModelOk;
  }
  template <class S>
  int outputs(std::span<const S> x, std::span<const double>, std::span<S> y) const {
    y[0] = x[0];
    return plant::kModelOk;
  }
};

// Two decoupled states: x0' = 0 (slow: a random walk once noise is added) and x1' = -rate x1
// (stiff: it forgets a disturbance in 1 / rate seconds). Outputs: both states.
struct SlowAndStiff {
  double rate = 1000.0;  // 1/s
  plant::ModelLayout layout() const {
    plant::ModelLayout l;
    for (const char* name : {"slow", "stiff"}) {
      l.states.push_back(plant::StateInfo{.name = name, .unit = "1", .abs_tol = 1e-12});
      l.outputs.push_back(plant::SignalInfo{.name = name, .unit = "1"});
    }
    return l;
  }
  template <class S>
  int rhs(std::span<const S> x, std::span<const double>, std::span<S> f) const {
    f[0] = S(0.0);
    f[1] = -rate * x[1];
    return plant::kModelOk;
  }
  template <class S>
  int outputs(std::span<const S> x, std::span<const double>, std::span<S> y) const {
    y[0] = x[0];
    y[1] = x[1];
    return plant::kModelOk;
  }
};

// A random walk with a second output, twice the state, that the model gets wrong by a
// structural error of 0.3 + 10 % (SignalInfo::model_error, model_error_rel).
struct StructuralError : RandomWalk {
  plant::ModelLayout layout() const {
    plant::ModelLayout l = RandomWalk::layout();
    l.outputs.push_back(plant::SignalInfo{
        .name = "twice", .unit = "1", .model_error = 0.3, .model_error_rel = 0.1});
    return l;
  }
  template <class S>
  int outputs(std::span<const S> x, std::span<const double>, std::span<S> y) const {
    y[0] = x[0];
    y[1] = 2.0 * x[0];
    return plant::kModelOk;
  }
};

// x' = 0, y = sqrt(x): at x = 0 the output Jacobian is infinite, which poisons an update.
struct SqrtSensor : RandomWalk {
  template <class S>
  int outputs(std::span<const S> x, std::span<const double>, std::span<S> y) const {
    using std::sqrt;
    y[0] = sqrt(x[0]);
    return plant::kModelOk;
  }
};

// A measured quantity and an unknown offset: x' = 0 for both, y = x + b; b is a consider state
// (StateInfo::consider) unless `estimate_offset`.
struct OffsetSensor {
  bool estimate_offset = false;
  bool augmented_offset = false;  // b an augmented state (StatePhases holds and releases it)
  plant::ModelLayout layout() const {
    plant::ModelLayout l;
    l.states.push_back(plant::StateInfo{.name = "x", .unit = "1", .abs_tol = 1e-10});
    l.states.push_back(plant::StateInfo{.name = "b",
                                        .unit = "1",
                                        .abs_tol = 1e-10,
                                        .augmented = augmented_offset,
                                        .consider = !estimate_offset});
    l.outputs.push_back(plant::SignalInfo{.name = "y", .unit = "1"});
    return l;
  }
  template <class S>
  int rhs(std::span<const S>, std::span<const double>, std::span<S> f) const {
    f[0] = f[1] = S(0.0);
    return plant::kModelOk;
  }
  template <class S>
  int outputs(std::span<const S> x, std::span<const double>, std::span<S> y) const {
    y[0] = x[0] + x[1];
    return plant::kModelOk;
  }
};

// A measured x and a consider state b, x' = b' = 0, input "speed"; y0 = x is measured, and the
// output constraint y1 = coupling x + b <= bound holds while speed >= 5 (always, unless
// `conditional`).
struct ConstrainedOutput {
  double coupling = 1.0, bound = 1.0;
  bool conditional = false;
  plant::ModelLayout layout() const {
    plant::ModelLayout l;
    l.states.push_back(plant::StateInfo{.name = "x", .unit = "1", .abs_tol = 1e-10});
    l.states.push_back(
        plant::StateInfo{.name = "b", .unit = "1", .abs_tol = 1e-10, .consider = true});
    l.inputs.push_back(plant::SignalInfo{.name = "speed", .unit = "Hz"});
    l.outputs.push_back(plant::SignalInfo{.name = "y0", .unit = "1"});
    l.outputs.push_back(plant::SignalInfo{.name = "y1", .unit = "1"});
    l.constraints.push_back(plant::LinearConstraint{.name = "y1 bounded",
                                                    .over = plant::LinearConstraint::Over::kOutputs,
                                                    .terms = {{1, 1.0}},
                                                    .bound = bound,
                                                    .while_input = conditional ? 0 : -1,
                                                    .while_above = 5.0});
    return l;
  }
  template <class S>
  int rhs(std::span<const S>, std::span<const double>, std::span<S> f) const {
    f[0] = f[1] = S(0.0);
    return plant::kModelOk;
  }
  template <class S>
  int outputs(std::span<const S> x, std::span<const double>, std::span<S> y) const {
    y[0] = x[0];
    y[1] = coupling * x[0] + x[1];
    return plant::kModelOk;
  }
};

}  // namespace hvac_twin::test
