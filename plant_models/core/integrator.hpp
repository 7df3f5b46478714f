// x_{k+1} = f(x_k, u_k) and F_k = dx_{k+1}/dx_k for a ContinuousModel, by SUNDIALS CVODES:
// variable-order BDF with a dense Newton solver fed the model's exact (AD) Jacobian, and, when
// asked, forward sensitivities with respect to the initial state (yS_j(0) = e_j, staggered
// corrector, sensitivity right-hand side J(x(t)) yS_j from the same AD Jacobian). F is therefore
// the state-transition matrix of the ODE to integrator tolerance, not a finite difference.
//
// Created once per unit (allocates all solver memory; throws std::runtime_error if SUNDIALS
// cannot be set up). step() re-initialises the solver and never allocates or throws.
// Not thread-safe: one instance per thread, each with its own model instance.
#pragma once

#include <array>
#include <cstddef>
#include <memory>
#include <span>

#include "plant_models/core/model.hpp"

namespace hvac_twin::plant {

struct IntegratorOptions {
  double rel_tol = 1e-6;
  // Absolute tolerance of state i is abs_tol_scale * layout().states[i].abs_tol.
  double abs_tol_scale = 1.0;
  long max_steps = 20000;      // per step() call
  double max_step_s = 0.0;     // largest internal step [s]; 0 = unlimited
  bool sensitivities = false;  // compute F in step()
  // Include sensitivities in the local error test. Off (the default), F rides on the steps the
  // state's own accuracy needs, with the staggered sensitivity corrector converged on each; on,
  // F meets the tolerances itself, at the price of many more steps for stiff models (on the
  // heat pump: 184 instead of 14 steps per 10 s, 240 ms instead of 28 ms). Absolute tolerance of
  // dx_i/dx0_j is abs_tol_i / (abs_tol_j / rel_tol): a perturbation of x0_j at its resolution
  // scale must move x_i by no more than x_i's own tolerance.
  bool sensitivity_error_control = false;
};

struct IntegrationStats {
  long steps = 0;
  long rhs_evals = 0;
  long jac_evals = 0;
  long sens_rhs_evals = 0;
  long error_test_failures = 0;
  long nonlinear_failures = 0;
};

struct IntegrationResult {
  int flag = 0;  // CVODES return flag of the last call (0 = success)
  [[nodiscard]] bool ok() const { return flag >= 0; }
};

class Integrator {
 public:
  Integrator(const ContinuousModel& model, const IntegratorOptions& options);
  ~Integrator();
  Integrator(const Integrator&) = delete;
  Integrator& operator=(const Integrator&) = delete;

  // Advances x (size n) by dt seconds with the inputs u held. When sensitivities are enabled
  // and F is not empty, writes F (n x n, column-major) = dx(dt)/dx(0). On failure x is left at
  // its initial value and F untouched.
  IntegrationResult step(std::span<double> x, std::span<const double> u, double dt,
                         std::span<double> F);

  [[nodiscard]] const IntegrationStats& last_stats() const { return stats_; }
  // The last message CVODES reported (empty if none); fixed storage, no allocation.
  [[nodiscard]] const char* last_error() const { return last_error_.data(); }
  [[nodiscard]] std::size_t size() const { return n_; }
  [[nodiscard]] const IntegratorOptions& options() const { return options_; }

 private:
  struct Sundials;  // SUNDIALS handles, hidden so no SUNDIALS header leaks to users
  friend struct IntegratorCallbacks;

  const ContinuousModel& model_;
  IntegratorOptions options_;
  std::size_t n_;
  std::unique_ptr<Sundials> s_;
  std::span<const double> u_;                  // inputs during the current step
  std::unique_ptr<double[]> jac_;              // n x n scratch for the sensitivity right-hand side
  std::unique_ptr<double[]> sens_, sens_dot_;  // n x n: sensitivities gathered, and J S
  IntegrationStats stats_;
  std::array<char, 256> last_error_{};
};

}  // namespace hvac_twin::plant
