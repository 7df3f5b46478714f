#include "plant_models/core/direct_sensitivity_solver.hpp"

#include <cvodes/cvodes.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_config.h>

#include <Eigen/Core>
#include <Eigen/LU>
#include <new>

#if SUNDIALS_VERSION_MAJOR != 6
#error "direct_sensitivity_solver relies on CVODES 6 (staggered corrector and vector wrapper)"
#endif

namespace hvac_twin::plant {
namespace {

// CVODES hands a staggered solver its ns sensitivity vectors wrapped in one N_Vector, SUNDIALS'
// "SensWrapper", whose header Debian does not install. Its content (unchanged since SUNDIALS 4):
struct SensWrapperContent {
  N_Vector* vecs;
  int nvecs;
  booleantype own_vecs;
};

// A vector wrapper of our own around ns serial vectors of length n, in the layout above; its
// operations are copied from one of CVODES's wrappers before first use.
struct OwnWrapper {
  N_Vector v = nullptr;
  SensWrapperContent content{nullptr, 0, SUNFALSE};

  bool create(SUNContext ctx, sunindextype n, int ns) {
    N_Vector tmpl = N_VNew_Serial(n, ctx);
    if (tmpl == nullptr) return false;
    content.vecs = N_VCloneVectorArray(ns, tmpl);
    N_VDestroy(tmpl);
    if (content.vecs == nullptr) return false;
    content.nvecs = ns;
    for (int j = 0; j < ns; ++j)
      N_VConst(0.0, content.vecs[j]);
    v = N_VNewEmpty(ctx);
    if (v == nullptr) return false;
    v->content = &content;
    return true;
  }
  void destroy() {
    if (v != nullptr) {
      v->content = nullptr;  // points at `content`, not at heap memory
      N_VFreeEmpty(v);
    }
    if (content.vecs != nullptr) N_VDestroyVectorArray(content.vecs, content.nvecs);
  }
};

struct Content {
  Content(Eigen::Index size, int count, StepJacobianFn fn, void* who)
      : n(size),
        ns(count),
        jacobian(fn),
        owner(who),
        M(size, size),
        B(size, count),
        X(size, count),
        J_lu(size, size),
        lu(size) {}
  ~Content() { zero.destroy(); }
  Content(const Content&) = delete;
  Content& operator=(const Content&) = delete;

  Eigen::Index n;
  int ns;
  StepJacobianFn jacobian;
  void* owner;
  Eigen::MatrixXd M, B, X;  // I - gamma J; right-hand sides; solution S_n
  // The J and gamma `lu` factorises I - gamma J of: a step with the same two (a reused
  // Jacobian, an unchanged step size and order) solves with the same factors.
  Eigen::MatrixXd J_lu;
  double gamma_lu = 0.0;
  bool lu_valid = false;
  Eigen::PartialPivLU<Eigen::MatrixXd> lu;
  SUNNonlinSolConvTestFn ctest = nullptr;
  void* ctest_data = nullptr;
  int cur_iter = 0;
  long iters = 0;       // of the last solve
  long conv_fails = 0;  // of the last solve
  long solves = 0;      // since creation
  // The zero update an exact solve leaves, for the convergence test (error control only).
  OwnWrapper zero;
  bool zero_ops = false;
  bool error_control = false;  // CVODES tests the sensitivities' local error (needs the ctest)
};

Content& content(SUNNonlinearSolver s) {
  return *static_cast<Content*>(s->content);
}

// The wrapped vectors of a SensWrapper, checked against the expected shape (null if not).
N_Vector* wrapped(N_Vector w, const Content& c) {
  const auto* sw = static_cast<const SensWrapperContent*>(w == nullptr ? nullptr : w->content);
  if (sw == nullptr || sw->vecs == nullptr || sw->nvecs != c.ns) return nullptr;
  for (int j = 0; j < c.ns; ++j)
    if (sw->vecs[j] == nullptr || N_VGetLength(sw->vecs[j]) != static_cast<sunindextype>(c.n))
      return nullptr;
  return sw->vecs;
}

Eigen::Map<Eigen::VectorXd> col(N_Vector v, Eigen::Index n) {
  return {N_VGetArrayPointer(v), n};
}

SUNNonlinearSolver_Type get_type(SUNNonlinearSolver) {
  return SUNNONLINEARSOLVER_ROOTFIND;
}
int initialize(SUNNonlinearSolver) {
  return SUN_NLS_SUCCESS;
}
int set_sys_fn(SUNNonlinearSolver, SUNNonlinSolSysFn) {
  return SUN_NLS_SUCCESS;  // the residual is known in closed form; CVODES's is not needed
}
int set_lsetup_fn(SUNNonlinearSolver, SUNNonlinSolLSetupFn) {
  return SUN_NLS_SUCCESS;  // the solver factorises its own matrix
}
int set_lsolve_fn(SUNNonlinearSolver, SUNNonlinSolLSolveFn) {
  return SUN_NLS_SUCCESS;
}
int set_ctest_fn(SUNNonlinearSolver s, SUNNonlinSolConvTestFn fn, void* data) {
  content(s).ctest = fn;
  content(s).ctest_data = data;
  return SUN_NLS_SUCCESS;
}
int set_max_iters(SUNNonlinearSolver, int) {
  return SUN_NLS_SUCCESS;  // one exact solve (two convergence tests) at most
}
int get_num_iters(SUNNonlinearSolver s, long int* n) {
  *n = content(s).iters;
  return SUN_NLS_SUCCESS;
}
int get_cur_iter(SUNNonlinearSolver s, int* i) {
  *i = content(s).cur_iter;
  return SUN_NLS_SUCCESS;
}
int get_num_conv_fails(SUNNonlinearSolver s, long int* n) {
  *n = content(s).conv_fails;
  return SUN_NLS_SUCCESS;
}

// ycor: the correction S_n - S_pred (out; CVODES's initial guess, zero, on entry); w: the error
// weights; mem: the CVODES memory. The first argument, CVODES's initial iterate, is not needed:
// its data accessors give the predicted sensitivities and the history.
int solve(SUNNonlinearSolver s, N_Vector, N_Vector ycor, N_Vector w, realtype tol,
          booleantype /*call_lsetup*/, void* mem) {
  Content& c = content(s);
  c.iters = 0;
  c.conv_fails = 0;
  c.cur_iter = 0;
  ++c.solves;
  N_Vector* out = wrapped(ycor, c);
  if (out == nullptr) return SUN_NLS_ILL_INPUT;
  if (c.error_control && !c.zero_ops) {
    if (N_VCopyOps(ycor, c.zero.v) != 0) return SUN_NLS_MEM_FAIL;
    c.zero_ops = true;
  }

  realtype t = 0.0, gamma = 0.0, rl1 = 0.0;
  N_Vector ypred = nullptr, yn = nullptr, fn = nullptr, zn1 = nullptr;
  N_Vector *s_pred = nullptr, *s_n = nullptr, *s_zn1 = nullptr;
  void* user_data = nullptr;
  if (CVodeGetNonlinearSystemData(mem, &t, &ypred, &yn, &fn, &gamma, &rl1, &zn1, &user_data) !=
          CV_SUCCESS ||
      CVodeGetNonlinearSystemDataSens(mem, &t, &s_pred, &s_n, &gamma, &rl1, &s_zn1, &user_data) !=
          CV_SUCCESS)
    return SUN_NLS_MEM_NULL;

  // J at the converged state y_n (the owner's cache serves repeated requests).
  const double* J = nullptr;
  const int status =
      c.jacobian(c.owner, {N_VGetArrayPointer(yn), static_cast<std::size_t>(c.n)}, &J);
  if (status != 0 || J == nullptr) {
    ++c.conv_fails;
    return status < 0 ? CV_SRHSFUNC_FAIL : SUN_NLS_CONV_RECVR;  // > 0: CVODES shrinks the step
  }
  const Eigen::Map<const Eigen::MatrixXd> Jm(J, c.n, c.n);
  if (!(c.lu_valid && gamma == c.gamma_lu && Jm == c.J_lu)) {
    c.M = -gamma * Jm;
    c.M.diagonal().array() += 1.0;
    c.lu.compute(c.M);
    c.lu_valid = c.lu.matrixLU().diagonal().cwiseAbs().minCoeff() > 0.0;
    if (!c.lu_valid) {
      ++c.conv_fails;
      return SUN_NLS_CONV_RECVR;
    }
    c.J_lu = Jm;
    c.gamma_lu = gamma;
  }
  for (int j = 0; j < c.ns; ++j)
    c.B.col(j) = col(s_pred[j], c.n) - rl1 * col(s_zn1[j], c.n);
  c.X = c.lu.solve(c.B);
  for (int j = 0; j < c.ns; ++j)
    col(out[j], c.n) = c.X.col(j) - col(s_pred[j], c.n);
  c.iters = 1;

  // CVODES's convergence test, as after an exact Newton iteration: the whole correction first;
  // if that is too large to pass, the zero update that follows it.
  if (!c.error_control || c.ctest == nullptr) return SUN_NLS_SUCCESS;
  int r = c.ctest(s, ycor, ycor, tol, w, c.ctest_data);
  if (r == SUN_NLS_CONTINUE) {
    c.cur_iter = 1;
    c.iters = 2;
    r = c.ctest(s, ycor, c.zero.v, tol, w, c.ctest_data);
  }
  if (r == SUN_NLS_SUCCESS) return SUN_NLS_SUCCESS;
  ++c.conv_fails;
  return r < 0 ? r : SUN_NLS_CONV_RECVR;
}

int free_solver(SUNNonlinearSolver s) {
  if (s == nullptr) return SUN_NLS_SUCCESS;
  delete static_cast<Content*>(s->content);
  s->content = nullptr;
  SUNNonlinSolFreeEmpty(s);
  return SUN_NLS_SUCCESS;
}

}  // namespace

SUNNonlinearSolver make_direct_sensitivity_solver(SUNContext ctx, sunindextype n, int ns,
                                                  bool error_control, StepJacobianFn jacobian,
                                                  void* owner) {
  SUNNonlinearSolver s = SUNNonlinSolNewEmpty(ctx);
  if (s == nullptr) return nullptr;
  auto* c = new (std::nothrow) Content(static_cast<Eigen::Index>(n), ns, jacobian, owner);
  s->content = c;
  if (c == nullptr) {
    SUNNonlinSolFreeEmpty(s);
    return nullptr;
  }
  c->error_control = error_control;
  if (error_control && !c->zero.create(ctx, n, ns)) {
    free_solver(s);
    return nullptr;
  }
  s->ops->gettype = get_type;
  s->ops->initialize = initialize;
  s->ops->solve = solve;
  s->ops->free = free_solver;
  s->ops->setsysfn = set_sys_fn;
  s->ops->setlsetupfn = set_lsetup_fn;
  s->ops->setlsolvefn = set_lsolve_fn;
  s->ops->setctestfn = set_ctest_fn;
  s->ops->setmaxiters = set_max_iters;
  s->ops->getnumiters = get_num_iters;
  s->ops->getcuriter = get_cur_iter;
  s->ops->getnumconvfails = get_num_conv_fails;
  return s;
}

long direct_sensitivity_solves(SUNNonlinearSolver s) {
  return s == nullptr ? 0 : content(s).solves;
}

}  // namespace hvac_twin::plant
