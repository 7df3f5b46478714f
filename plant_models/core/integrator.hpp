// x_{k+1} = f(x_k, u_k) and F_k = dx_{k+1}/dx_k for a ContinuousModel, by SUNDIALS CVODES:
// variable-order BDF with a dense Newton solver fed the model's exact (AD) Jacobian, and, when
// asked, forward sensitivities with respect to the initial state (yS_j(0) = e_j, staggered
// corrector). F is the derivative of the integrator's own solution, not a finite difference;
// it is the state-transition matrix of the ODE to the integrator's tolerance when F is under error
// control (sensitivity_error_control), and otherwise as accurate as the steps the state needs
// make it (see there).
//
// Sensitivities (SensitivityMethod): by default each
// accepted step's sensitivity system
// (I - gamma J(x_n)) S_n = (CVODES's predicted history) is solved exactly and for all n columns
// at once, with one Jacobian at the step's state and one LU factorisation
// (direct_sensitivity_solver.hpp): F is the derivative of CVODES's own BDF steps, at about one
// Jacobian per step. kCvodesNewton keeps CVODES's own corrector (per-column Newton iterations with
// the state's lagged iteration matrix, a Jacobian-times-S right-hand side per iteration), the
// reference the default is checked against. kExponential integrates the state alone and
// composes F of matrix exponentials of the Jacobian along the trajectory
// (matrix_exponential.hpp): exact for a linear model whatever the steps, where the sensitivity
// systems are only as exact as the BDF steps they are solved on. Every way the model Jacobian is
// evaluated at most once per distinct state (jacobian_cache.hpp): CVODES's Newton matrix, the
// sensitivity right-hand side, the direct solve and the exponential's segments share it.
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

class JacobianCache;

// How step() computes F (see above).
enum class SensitivityMethod {
  kDirect,        // exact per-step solve, all columns at once (default)
  kCvodesNewton,  // CVODES's staggered Newton corrector, column by column (reference)
  // The state alone by CVODES (no sensitivity system, so no sensitivity error control), F as the
  // product of matrix exponentials over segments of the trajectory, one segment while no state
  // has moved more than jacobian_reuse_sigma from the segment's start: exp(J_mid (t_end -
  // t_start)), J_mid the mean of the Jacobians at both ends (the trapezoidal rule: exact for a
  // linear model, second order in the segment's length otherwise). The state's own steps
  // decide where segments end; F's fast modes need no steps of their own, since the
  // exponential resolves them exactly. Needs jacobian_reuse_sigma > 0 to be cheaper than a
  // segment per step.
  kExponential,
};

struct IntegratorOptions {
  double rel_tol = 1e-6;
  // Absolute tolerance of state i is abs_tol_scale * layout().states[i].abs_tol.
  double abs_tol_scale = 1.0;
  long max_steps = 20000;      // per step() call
  double max_step_s = 0.0;     // largest internal step [s]; 0 = unlimited
  bool sensitivities = false;  // compute F in step()
  // kDirect and kCvodesNewton (kExponential has no sensitivity system to test).
  // Include sensitivities in the local error test. Off (the default), F rides on the steps the
  // state's own accuracy needs, solved exactly on each; on, F meets the tolerances itself, at the
  // price of more steps. Absolute tolerance of dx_i/dx0_j is abs_tol_i / (abs_tol_j / rel_tol):
  // a perturbation of x0_j at its resolution scale must move x_i by no more than x_i's own
  // tolerance. Measured on the heat pump (N = 10, 5 s from a settled state, error of D^-1 F D
  // against a tight reference, D the states' resolution scales): off, 3 steps and 26 % (the state
  // at rest takes steps far longer than F's modes); on, 144 steps and 2e-7; on with
  // sensitivity_rel_tol 1e-2, 36 steps and 2e-3. On transients the state's steps resolve F too
  // (off: 1e-4 to 1e-3).
  bool sensitivity_error_control = false;
  // Relative tolerance of F under sensitivity_error_control (0: rel_tol); the absolute ones scale
  // with it (abs_tol_i / (abs_tol_j / rel_tol) * sensitivity_rel_tol / rel_tol).
  double sensitivity_rel_tol = 0.0;
  SensitivityMethod sensitivity_method = SensitivityMethod::kDirect;
  // kDirect only, for comparisons: solve each step's sensitivity system with the Jacobian
  // CVODES's Newton iteration last evaluated (it keeps one while its iteration converges),
  // instead of one at every step's state. Cheaper by the Jacobians, but F is then the derivative
  // of BDF steps on a model linearised at an older state. Measured on the heat pump
  // (race_bench --reuse-jacobians): the step half as costly, and the outputs' sigma 20 % off in
  // the period after a large update (exact: 0.01 %). Off (the default): the exact derivative of
  // CVODES's steps, one Jacobian per step.
  bool reuse_newton_jacobian = false;
  // Reuse one model Jacobian, for the steps' sensitivity solves (kDirect), CVODES's Newton
  // matrix and the sensitivity right-hand sides, while no state has moved by more than this many of
  // its initial_std (the layout's) from the state it was evaluated at; 0 (the default): a Jacobian
  // at every step's own state. F is then the derivative of BDF steps on the model linearised within
  // that distance of each step's state. Unlike reuse_newton_jacobian the reuse ends when the state
  // moves, not when CVODES's iteration stops converging (race_bench --jacobian-reuse measures the
  // trade). The Jacobian is also kept from one step() to the next while every input stays within
  // this distance of the inputs it was evaluated at, in units of the input's reuse_scale (the
  // layout's; 0 for an input without one: any change of it ends the reuse), and with it
  // kExponential's last matrix exponential (the same Jacobians and segment length give the same
  // exponential): a unit in steady operation evaluates neither in most periods. CVODES's Newton
  // matrix after a failed Newton iteration is always evaluated afresh at its own state.
  double jacobian_reuse_sigma = 0.0;
};

struct IntegrationStats {
  long steps = 0;
  long rhs_evals = 0;
  long jac_evals = 0;
  long sens_rhs_evals = 0;   // CVODES sensitivity right-hand sides (J S products)
  long sens_solves = 0;      // direct sensitivity solves (kDirect: one per accepted step)
  long model_jacobians = 0;  // model Jacobians evaluated (each distinct state once)
  long jacobian_reuses = 0;  // Jacobian requests served from the one already evaluated
  long segments = 0;         // kExponential: matrix exponentials F was composed of
  long exponentials = 0;     // of them computed; the others repeated the last one computed
                             // (the same Jacobians and length, see jacobian_reuse_sigma)
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
  // its initial value and F untouched. kExponential: where a segment's exponential overflows (a
  // state whose linearisation has a mode growing by more than e^709 over the segment, e.g. an
  // evaporator cell an update left below the one upstream of it, which CVODES resolves in steps
  // of microseconds), the period is integrated again with F by CVODES's own sensitivities,
  // which follow the growth step by step and saturate with the state.
  IntegrationResult step(std::span<double> x, std::span<const double> u, double dt,
                         std::span<double> F);

  // A constant rate added to the model's right-hand side in the following step() calls, until
  // set again (empty: none): dx/dt = f(x, u) + g. The span must outlive those calls. The model's
  // Jacobian is the system's (g does not depend on x). For an ensemble member's process noise
  // held over the period (ConstrainedEnkf::predict).
  void set_forcing(std::span<const double> g) { forcing_ = g; }

  // Forgets the kept Jacobian and exponential: the next step() evaluates its own, whatever the
  // reuse distance (after a reset or a jump of the state the owner does not trust them).
  void forget_jacobian();

  [[nodiscard]] const IntegrationStats& last_stats() const { return stats_; }
  // kExponential: the periods whose F fell back to CVODES's own sensitivities (see step()).
  [[nodiscard]] long fallbacks() const { return fallbacks_; }
  // The last message CVODES reported (empty if none); fixed storage, no allocation.
  [[nodiscard]] const char* last_error() const { return last_error_.data(); }
  [[nodiscard]] std::size_t size() const { return n_; }
  [[nodiscard]] const IntegratorOptions& options() const { return options_; }

 private:
  struct Sundials;    // SUNDIALS handles, hidden so no SUNDIALS header leaks to users
  struct Transition;  // kExponential's workspace
  friend struct IntegratorCallbacks;

  // kExponential: integrates to dt one CVODES step at a time, composing F by segments.
  int exponential_steps(double dt, std::span<double> F);

  const ContinuousModel& model_;
  IntegratorOptions options_;
  std::size_t n_;
  std::unique_ptr<Sundials> s_;
  std::span<const double> u_;                 // inputs during the current step
  std::span<const double> forcing_;           // added to the right-hand side (set_forcing)
  std::unique_ptr<JacobianCache> jacobians_;  // J at the last state asked for
  std::unique_ptr<Transition> transition_;    // kExponential only
  // kExponential: the same options but F by CVODES's corrector, for a period whose exponentials
  // overflow (step()); built with this one, so that falling back allocates nothing.
  std::unique_ptr<Integrator> fallback_;
  long fallbacks_ = 0;
  bool exponential_failed_ = false;            // this step()'s segment exponential failed
  std::unique_ptr<double[]> sens_, sens_dot_;  // n x n: sensitivities gathered, and J S
  IntegrationStats stats_;
  long newton_failures_seen_ = 0;  // CVODES's count at this step()'s last Jacobian request
  std::array<char, 256> last_error_{};
};

}  // namespace hvac_twin::plant
