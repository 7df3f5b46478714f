// The interface every plant model presents to the integrator and the estimators.
//
//   x' = f(x, u)        continuous-time dynamics, u held constant over a step (zero-order hold)
//   y  = h(x, u)        outputs: everything computable from the state that a sensor measures or
//                       a virtual sensor publishes
//
// Models are written once as templates over the scalar type (see ad_model.hpp); this interface
// is the type-erased view with exact Jacobians. Matrices are dense, column-major, with leading
// dimension equal to their row count: J[c * n + r] = df_r/dx_c, H[c * m + r] = dh_r/dx_c.
//
// Status convention (SUNDIALS): 0 success, > 0 recoverable (e.g. a property call left its table;
// the integrator retries with a smaller step), < 0 fatal. Calls never throw.
//
// Thread-safety: a model instance keeps scratch space for derivatives, so one instance serves one
// thread; clone() makes another (start-up only, allocates). Evaluation never allocates.
#pragma once

#include <cstddef>
#include <memory>
#include <span>

#include "plant_models/core/model_info.hpp"

namespace hvac_twin::plant {

inline constexpr int kModelOk = 0;
inline constexpr int kModelRecoverable = 1;
inline constexpr int kModelFatal = -1;

class ContinuousModel {
 public:
  virtual ~ContinuousModel() = default;
  ContinuousModel() = default;
  ContinuousModel(const ContinuousModel&) = delete;
  ContinuousModel& operator=(const ContinuousModel&) = delete;

  [[nodiscard]] virtual const ModelLayout& layout() const = 0;
  [[nodiscard]] std::size_t num_states() const { return layout().states.size(); }
  [[nodiscard]] std::size_t num_inputs() const { return layout().inputs.size(); }
  [[nodiscard]] std::size_t num_outputs() const { return layout().outputs.size(); }

  virtual int rhs(std::span<const double> x, std::span<const double> u,
                  std::span<double> xdot) const = 0;
  // f and J = df/dx (n x n). xdot may be empty when only J is wanted.
  virtual int rhs_jacobian(std::span<const double> x, std::span<const double> u,
                           std::span<double> xdot, std::span<double> jac) const = 0;
  virtual int outputs(std::span<const double> x, std::span<const double> u,
                      std::span<double> y) const = 0;
  // h and H = dh/dx (m x n). y may be empty when only H is wanted.
  virtual int output_jacobian(std::span<const double> x, std::span<const double> u,
                              std::span<double> y, std::span<double> jac) const = 0;

  // A consistent starting state at the conditions the first cycle sees: the inputs u, and the
  // measured outputs y (NaN where not measured). Models whose state must be internally
  // consistent (the heat pump's masses, pressures and enthalpies) implement it; false: use the
  // layout's defaults. Start-up only (may allocate).
  virtual bool initial_guess(std::span<const double> u, std::span<const double> y,
                             std::span<double> x) const {
    (void)u;
    (void)y;
    (void)x;
    return false;
  }

  // Non-null once the model can never be evaluated again (an FMU that returned fmi2Error or
  // fmi2Fatal: every call is kModelFatal from then on): what it said. Built-in models never fail
  // for good.
  [[nodiscard]] virtual const char* failure() const { return nullptr; }

  [[nodiscard]] virtual std::unique_ptr<ContinuousModel> clone() const = 0;
};

}  // namespace hvac_twin::plant
