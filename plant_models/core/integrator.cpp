#include "plant_models/core/integrator.hpp"

#include <cvodes/cvodes.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>

#include <Eigen/Core>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>

#include "plant_models/core/direct_sensitivity_solver.hpp"
#include "plant_models/core/eigen_dense_solver.hpp"
#include "plant_models/core/jacobian_cache.hpp"
#include "plant_models/core/matrix_exponential.hpp"

namespace hvac_twin::plant {

struct Integrator::Sundials {
  SUNContext ctx = nullptr;
  void* cvode = nullptr;
  N_Vector y = nullptr;
  N_Vector abs_tol = nullptr;
  SUNMatrix jac = nullptr;
  SUNLinearSolver ls = nullptr;
  N_Vector* yS = nullptr;         // sensitivities, one vector per initial-state component
  N_Vector* abs_tol_S = nullptr;  // their absolute tolerances
  SUNNonlinearSolver sens_solver = nullptr;  // kDirect: ours, freed after CVODES
  int ns = 0;

  ~Sundials() {
    if (abs_tol_S != nullptr) N_VDestroyVectorArray(abs_tol_S, ns);
    if (yS != nullptr) N_VDestroyVectorArray(yS, ns);
    if (cvode != nullptr) CVodeFree(&cvode);
    if (sens_solver != nullptr) SUNNonlinSolFree(sens_solver);
    if (ls != nullptr) SUNLinSolFree(ls);
    if (jac != nullptr) SUNMatDestroy(jac);
    if (abs_tol != nullptr) N_VDestroy(abs_tol);
    if (y != nullptr) N_VDestroy(y);
    if (ctx != nullptr) SUNContext_Free(&ctx);
  }
};

struct Integrator::Transition {
  explicit Transition(Eigen::Index n)
      : F(n, n), J_start(n, n), J_mid(n, n), E(n, n), T(n, n), y_start(n), expm(n) {}
  Eigen::MatrixXd F;        // the transition from 0 to the current segment's start
  Eigen::MatrixXd J_start;  // the Jacobian at the segment's start
  Eigen::MatrixXd J_mid, E, T;
  Eigen::VectorXd y_start;  // the state there
  MatrixExponential expm;
  long segments = 0;      // since creation, for statistics
  long exponentials = 0;  // of them computed (the others were the last one again)
  // What E was last computed of: the Jacobians' evaluation numbers at the segment's ends
  // (JacobianCache::evaluations()) and its length. A unit in steady operation keeps one
  // Jacobian over many periods of the same length, and with it one exponential.
  long e_start = -1, e_end = -1;
  double e_length = 0.0;
};

// CVODES callbacks. They never throw; model status codes pass straight through (0 ok, > 0
// recoverable: CVODES retries with a smaller step, < 0 fatal).
struct IntegratorCallbacks {
  static Integrator& self(void* user_data) { return *static_cast<Integrator*>(user_data); }
  static std::span<double> view(N_Vector v) {
    return {N_VGetArrayPointer(v), static_cast<std::size_t>(N_VGetLength(v))};
  }

  static int rhs(realtype /*t*/, N_Vector y, N_Vector ydot, void* user_data) {
    Integrator& it = self(user_data);
    const int status = it.model_.rhs(view(y), it.u_, view(ydot));
    if (status == 0 && !it.forcing_.empty()) {
      double* d = N_VGetArrayPointer(ydot);
      for (std::size_t i = 0; i < it.n_; ++i)
        d[i] += it.forcing_[i];
    }
    return status;
  }

  // CVODES asks for a Jacobian at a step's first iterate when its own copy is too old, and after
  // a Newton iteration failed to converge. The second is a request for a fresh matrix: a kept one
  // (jacobian_reuse_sigma) is the likely cause of the failure, and handing it back would fail
  // again and again, each time on a smaller step.
  static int jacobian(realtype /*t*/, N_Vector y, N_Vector /*fy*/, SUNMatrix jac, void* user_data,
                      N_Vector, N_Vector, N_Vector) {
    Integrator& it = self(user_data);
    long failures = 0;
    CVodeGetNumNonlinSolvConvFails(it.s_->cvode, &failures);
    const bool after_failure = failures > it.newton_failures_seen_;
    it.newton_failures_seen_ = failures;
    const double* J = nullptr;
    const int status = it.jacobians_->get_near(
        view(y), it.u_, after_failure ? 0.0 : it.options_.jacobian_reuse_sigma, &J);
    if (status != kModelOk) return status;
    std::memcpy(SUNDenseMatrix_Data(jac), J, it.n_ * it.n_ * sizeof(double));  // ld = n
    return 0;
  }

  // ySdot_j = J(y) yS_j: the variational equation of the initial-value problem.
  static int sensitivity_rhs(int ns, realtype /*t*/, N_Vector y, N_Vector /*ydot*/, N_Vector* yS,
                             N_Vector* ySdot, void* user_data, N_Vector, N_Vector) {
    Integrator& it = self(user_data);
    const auto n = static_cast<Eigen::Index>(it.n_);
    const double* jac = nullptr;
    const int status =
        it.jacobians_->get_near(view(y), it.u_, it.options_.jacobian_reuse_sigma, &jac);
    if (status != kModelOk) return status;
    // One matrix product for all sensitivities: gather S, multiply, scatter.
    const Eigen::Map<const Eigen::MatrixXd> J(jac, n, n);
    Eigen::Map<Eigen::MatrixXd> S(it.sens_.get(), n, ns), Sdot(it.sens_dot_.get(), n, ns);
    for (int j = 0; j < ns; ++j)
      S.col(j) = Eigen::Map<const Eigen::VectorXd>(N_VGetArrayPointer(yS[j]), n);
    Sdot.noalias() = J * S;
    for (int j = 0; j < ns; ++j)
      Eigen::Map<Eigen::VectorXd>(N_VGetArrayPointer(ySdot[j]), n) = Sdot.col(j);
    return 0;
  }

  // J at a step's converged state, for the direct sensitivity solver; with
  // reuse_newton_jacobian, the Newton iteration's if there is one.
  static int step_jacobian(void* owner, std::span<const double> y, const double** J) {
    Integrator& it = self(owner);
    if (it.options_.reuse_newton_jacobian) {
      *J = it.jacobians_->latest();
      if (*J != nullptr) return kModelOk;
    }
    return it.jacobians_->get_near(y, it.u_, it.options_.jacobian_reuse_sigma, J);
  }

  static void error_handler(int /*code*/, const char* module, const char* function, char* msg,
                            void* user_data) {
    Integrator& it = self(user_data);
    std::snprintf(it.last_error_.data(), it.last_error_.size(), "%s/%s: %s", module, function, msg);
  }
};

namespace {

void check(int flag, const char* what) {
  if (flag < 0) throw std::runtime_error(std::string("CVODES set-up failed in ") + what);
}

template <class T>
T* check_ptr(T* p, const char* what) {
  if (p == nullptr) throw std::runtime_error(std::string("SUNDIALS allocation failed: ") + what);
  return p;
}

}  // namespace

Integrator::Integrator(const ContinuousModel& model, const IntegratorOptions& options)
    : model_(model),
      options_(options),
      n_(model.num_states()),
      s_(std::make_unique<Sundials>()),
      jacobians_(std::make_unique<JacobianCache>(model, n_)),
      sens_(new double[n_ * n_]()),
      sens_dot_(new double[n_ * n_]()) {
  if (n_ == 0) throw std::invalid_argument("integrator: model has no states");
  const auto n = static_cast<sunindextype>(n_);
  Sundials& s = *s_;
  check(SUNContext_Create(nullptr, &s.ctx), "SUNContext_Create");
  s.y = check_ptr(N_VNew_Serial(n, s.ctx), "state vector");
  s.abs_tol = check_ptr(N_VNew_Serial(n, s.ctx), "tolerance vector");
  const auto& states = model_.layout().states;
  double* atol = N_VGetArrayPointer(s.abs_tol);
  for (std::size_t i = 0; i < n_; ++i)
    atol[i] = options_.abs_tol_scale * states[i].abs_tol;

  s.cvode = check_ptr(CVodeCreate(CV_BDF, s.ctx), "CVodeCreate");
  check(CVodeSetErrHandlerFn(s.cvode, &IntegratorCallbacks::error_handler, this), "err handler");
  N_VConst(0.0, s.y);
  check(CVodeInit(s.cvode, &IntegratorCallbacks::rhs, 0.0, s.y), "CVodeInit");
  check(CVodeSetUserData(s.cvode, this), "CVodeSetUserData");
  check(CVodeSVtolerances(s.cvode, options_.rel_tol, s.abs_tol), "CVodeSVtolerances");
  s.jac = check_ptr(SUNDenseMatrix(n, n, s.ctx), "Jacobian matrix");
  s.ls = check_ptr(make_eigen_dense_solver(s.ctx, n), "dense linear solver");
  check(CVodeSetLinearSolver(s.cvode, s.ls, s.jac), "CVodeSetLinearSolver");
  check(CVodeSetJacFn(s.cvode, &IntegratorCallbacks::jacobian), "CVodeSetJacFn");
  check(CVodeSetMaxNumSteps(s.cvode, options_.max_steps), "CVodeSetMaxNumSteps");
  if (options_.max_step_s > 0.0) check(CVodeSetMaxStep(s.cvode, options_.max_step_s), "max step");

  if (options_.sensitivities && options_.sensitivity_method == SensitivityMethod::kExponential) {
    transition_ = std::make_unique<Transition>(static_cast<Eigen::Index>(n_));
    IntegratorOptions fallback = options_;
    fallback.sensitivity_method = SensitivityMethod::kCvodesNewton;
    fallback_ = std::make_unique<Integrator>(model, fallback);
  } else if (options_.sensitivities) {
    s.ns = static_cast<int>(n_);
    const double sens_tol =
        options_.sensitivity_rel_tol > 0.0 ? options_.sensitivity_rel_tol : options_.rel_tol;
    // Fused vector operations: CVODES then updates all sensitivity vectors in one call per
    // operation instead of one call per vector.
    check(N_VEnableFusedOps_Serial(s.y, SUNTRUE), "fused vector operations");
    s.yS = check_ptr(N_VCloneVectorArray(s.ns, s.y), "sensitivity vectors");
    s.abs_tol_S = check_ptr(N_VCloneVectorArray(s.ns, s.y), "sensitivity tolerances");
    for (int j = 0; j < s.ns; ++j) {
      N_VConst(0.0, s.yS[j]);
      const double scale_j = atol[j] / options_.rel_tol;  // resolution scale of x0_j
      double* a = N_VGetArrayPointer(s.abs_tol_S[j]);
      for (std::size_t i = 0; i < n_; ++i)
        a[i] = sens_tol / options_.rel_tol * atol[i] / scale_j;
    }
    check(CVodeSensInit(s.cvode, s.ns, CV_STAGGERED, &IntegratorCallbacks::sensitivity_rhs, s.yS),
          "CVodeSensInit");
    check(CVodeSensSVtolerances(s.cvode, sens_tol, s.abs_tol_S), "sens tolerances");
    check(CVodeSetSensErrCon(s.cvode, options_.sensitivity_error_control ? SUNTRUE : SUNFALSE),
          "CVodeSetSensErrCon");
    if (options_.sensitivity_method == SensitivityMethod::kDirect) {
      s.sens_solver = check_ptr(
          make_direct_sensitivity_solver(s.ctx, n, s.ns, options_.sensitivity_error_control,
                                         &IntegratorCallbacks::step_jacobian, this),
          "direct sensitivity solver");
      check(CVodeSetNonlinearSolverSensStg(s.cvode, s.sens_solver), "sensitivity solver");
    }
  }
}

Integrator::~Integrator() = default;

void Integrator::forget_jacobian() {
  jacobians_->begin({}, 0.0);
  if (transition_ != nullptr) transition_->e_start = -1;
}

IntegrationResult Integrator::step(std::span<double> x, std::span<const double> u, double dt,
                                   std::span<double> F) {
  Sundials& s = *s_;
  last_error_[0] = '\0';
  u_ = u;
  // u may have changed since the last call: the Jacobian is kept only within the reuse distance.
  jacobians_->begin(u, options_.jacobian_reuse_sigma);
  const long jacobians0 = jacobians_->evaluations(), reuses0 = jacobians_->hits();
  const long solves0 = direct_sensitivity_solves(s.sens_solver);
  const long segments0 = transition_ != nullptr ? transition_->segments : 0;
  const long exponentials0 = transition_ != nullptr ? transition_->exponentials : 0;
  double* y = N_VGetArrayPointer(s.y);
  std::memcpy(y, x.data(), n_ * sizeof(double));
  IntegrationResult result;
  result.flag = CVodeReInit(s.cvode, 0.0, s.y);  // CVODES's counters start again from 0
  newton_failures_seen_ = 0;
  if (result.flag >= 0 && transition_ == nullptr && options_.sensitivities) {
    for (int j = 0; j < s.ns; ++j) {
      N_VConst(0.0, s.yS[j]);
      N_VGetArrayPointer(s.yS[j])[j] = 1.0;
    }
    result.flag = CVodeSensReInit(s.cvode, CV_STAGGERED, s.yS);
  }
  if (result.flag >= 0) result.flag = CVodeSetStopTime(s.cvode, dt);
  double t = 0.0;
  exponential_failed_ = false;
  if (result.flag >= 0) {
    if (transition_ != nullptr && !F.empty())
      result.flag = exponential_steps(dt, F);
    else
      result.flag = CVode(s.cvode, dt, s.y, &t, CV_NORMAL);
  }
  if (exponential_failed_) {
    // x is untouched on failure: the period again, F by CVODES's sensitivities. The kept
    // Jacobian and exponential describe a state the next period should not trust.
    forget_jacobian();
    ++fallbacks_;
    const IntegrationResult again = fallback_->step(x, u, dt, F);
    stats_ = fallback_->last_stats();
    if (!again.ok())
      std::snprintf(last_error_.data(), last_error_.size(), "%s", fallback_->last_error());
    return again;
  }

  stats_ = {};
  CVodeGetNumSteps(s.cvode, &stats_.steps);
  CVodeGetNumRhsEvals(s.cvode, &stats_.rhs_evals);
  CVodeGetNumJacEvals(s.cvode, &stats_.jac_evals);
  CVodeGetNumErrTestFails(s.cvode, &stats_.error_test_failures);
  CVodeGetNumNonlinSolvConvFails(s.cvode, &stats_.nonlinear_failures);
  if (s.ns > 0) CVodeGetSensNumRhsEvals(s.cvode, &stats_.sens_rhs_evals);
  stats_.sens_solves = direct_sensitivity_solves(s.sens_solver) - solves0;
  stats_.model_jacobians = jacobians_->evaluations() - jacobians0;
  stats_.jacobian_reuses = jacobians_->hits() - reuses0;
  if (transition_ != nullptr) {
    stats_.segments = transition_->segments - segments0;
    stats_.exponentials = transition_->exponentials - exponentials0;
  }
  if (result.flag < 0) return result;

  if (s.ns > 0 && !F.empty()) {
    result.flag = CVodeGetSens(s.cvode, &t, s.yS);
    if (result.flag < 0) return result;
    for (int j = 0; j < s.ns; ++j)
      std::memcpy(&F[static_cast<std::size_t>(j) * n_], N_VGetArrayPointer(s.yS[j]),
                  n_ * sizeof(double));
  }
  std::memcpy(x.data(), y, n_ * sizeof(double));
  return result;
}

int Integrator::exponential_steps(double dt, std::span<double> F) {
  Sundials& s = *s_;
  Transition& tr = *transition_;
  const auto n = static_cast<Eigen::Index>(n_);
  const std::span<const double> y{N_VGetArrayPointer(s.y), n_};
  const std::span<const double> y_start{tr.y_start.data(), n_};
  const double reuse = options_.jacobian_reuse_sigma;
  const auto report = [&](const char* what, double t) {
    std::snprintf(last_error_.data(), last_error_.size(), "integrator: %s at t = %g s", what, t);
    return CV_RHSFUNC_FAIL;
  };
  // The Jacobian at y, copied to `to` (the cache keeps one matrix, and CVODES's Newton matrix
  // may replace it).
  const auto jacobian_at = [&](Eigen::MatrixXd& to) {
    const double* J = nullptr;
    const int status = jacobians_->get_near(y, u_, reuse, &J);
    if (status != kModelOk || J == nullptr) return false;
    to = Eigen::Map<const Eigen::MatrixXd>(J, n, n);
    return true;
  };
  if (!jacobian_at(tr.J_start)) return report("no model Jacobian at the initial state", 0.0);
  long j_start = jacobians_->evaluations();
  tr.y_start = Eigen::Map<const Eigen::VectorXd>(y.data(), n);
  double t_start = 0.0, t = 0.0;
  bool first = true;  // F is the identity until the first segment ends
  for (long steps = 1;; ++steps) {
    if (steps > options_.max_steps) {
      report("too many steps", t);
      return CV_TOO_MUCH_WORK;
    }
    const int flag = CVode(s.cvode, dt, s.y, &t, CV_ONE_STEP);
    if (flag < 0) return flag;
    const bool end = flag == CV_TSTOP_RETURN || t >= dt;
    if (!end && jacobians_->within(y, y_start, reuse)) continue;
    // The segment [t_start, t] ends: F <- exp((J_start + J_end) / 2 (t - t_start)) F.
    if (!jacobian_at(tr.T)) return report("no model Jacobian", t);
    const long j_end = jacobians_->evaluations();
    const double length = t - t_start;
    if (j_start != tr.e_start || j_end != tr.e_end || length != tr.e_length) {
      tr.e_start = -1;  // E is being replaced
      tr.J_mid = 0.5 * length * (tr.J_start + tr.T);
      if (!tr.expm.compute(tr.J_mid, tr.E)) {
        exponential_failed_ = true;
        return report("no matrix exponential", t);
      }
      tr.e_start = j_start;
      tr.e_end = j_end;
      tr.e_length = length;
      ++tr.exponentials;
    }
    tr.J_start = tr.T;
    j_start = j_end;
    if (first) {
      tr.F = tr.E;
    } else {
      tr.T.noalias() = tr.E * tr.F;
      tr.F = tr.T;
    }
    first = false;
    ++tr.segments;
    if (end) break;
    tr.y_start = Eigen::Map<const Eigen::VectorXd>(y.data(), n);
    t_start = t;
  }
  Eigen::Map<Eigen::MatrixXd>(F.data(), n, n) = tr.F;
  return CV_SUCCESS;
}

}  // namespace hvac_twin::plant
