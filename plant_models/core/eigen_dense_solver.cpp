#include "plant_models/core/eigen_dense_solver.hpp"

#include <nvector/nvector_serial.h>
#include <sunmatrix/sunmatrix_dense.h>

#include <Eigen/Core>
#include <Eigen/LU>
#include <new>

namespace hvac_twin::plant {
namespace {

struct Content {
  explicit Content(Eigen::Index size) : lu(size), work(size), n(size) {}
  Eigen::PartialPivLU<Eigen::MatrixXd> lu;
  Eigen::VectorXd work;
  Eigen::Index n;
  sunindextype last_flag = 0;
};

Content& content(SUNLinearSolver s) {
  return *static_cast<Content*>(s->content);
}

SUNLinearSolver_Type get_type(SUNLinearSolver) {
  return SUNLINEARSOLVER_DIRECT;
}
SUNLinearSolver_ID get_id(SUNLinearSolver) {
  return SUNLINEARSOLVER_CUSTOM;
}
int initialize(SUNLinearSolver) {
  return SUNLS_SUCCESS;
}

int setup(SUNLinearSolver s, SUNMatrix A) {
  Content& c = content(s);
  c.lu.compute(Eigen::Map<const Eigen::MatrixXd>(SUNDenseMatrix_Data(A), c.n, c.n));
  // A zero pivot: singular (recoverable, CVODES retries with a smaller step).
  if (!(c.lu.matrixLU().diagonal().cwiseAbs().minCoeff() > 0.0)) {
    c.last_flag = 1;
    return SUNLS_LUFACT_FAIL;
  }
  c.last_flag = 0;
  return SUNLS_SUCCESS;
}

int solve(SUNLinearSolver s, SUNMatrix, N_Vector x, N_Vector b, realtype) {
  Content& c = content(s);
  c.work = c.lu.solve(Eigen::Map<const Eigen::VectorXd>(N_VGetArrayPointer(b), c.n));
  Eigen::Map<Eigen::VectorXd>(N_VGetArrayPointer(x), c.n) = c.work;
  return SUNLS_SUCCESS;
}

sunindextype last_flag(SUNLinearSolver s) {
  return content(s).last_flag;
}

int free_solver(SUNLinearSolver s) {
  if (s == nullptr) return SUNLS_SUCCESS;
  delete static_cast<Content*>(s->content);
  s->content = nullptr;
  SUNLinSolFreeEmpty(s);
  return SUNLS_SUCCESS;
}

}  // namespace

SUNLinearSolver make_eigen_dense_solver(SUNContext ctx, sunindextype n) {
  SUNLinearSolver s = SUNLinSolNewEmpty(ctx);
  if (s == nullptr) return nullptr;
  s->content = new (std::nothrow) Content(static_cast<Eigen::Index>(n));
  if (s->content == nullptr) {
    SUNLinSolFreeEmpty(s);
    return nullptr;
  }
  s->ops->gettype = get_type;
  s->ops->getid = get_id;
  s->ops->initialize = initialize;
  s->ops->setup = setup;
  s->ops->solve = solve;
  s->ops->lastflag = last_flag;
  s->ops->free = free_solver;
  return s;
}

}  // namespace hvac_twin::plant
