// A SUNNonlinearSolver for CVODES's staggered forward-sensitivity corrector that solves each
// step's sensitivity system exactly, for all columns at once. Private to the integrator.
//
// At every accepted step t_n (order q, gamma = h / l_1), once the state y_n has passed its error
// test, the BDF corrector for the sensitivities S = dy/dy(0) (n x ns) is the *linear* system
//
//     (I - gamma J(y_n)) S_n = S_pred - rl1 * S'_1        (ycor = S_n - S_pred)
//
// with S_pred and S'_1 the first two columns of CVODES's Nordsieck history of S. CVODES's own
// Newton corrector iterates on it with the state's (older, lagged) iteration matrix, one
// sensitivity right-hand side J(y_n) S and one triangular solve per column per iteration. This
// solver instead takes J(y_n) once, factorises I - gamma J(y_n) once (partial-pivoting LU) and
// solves the ns right-hand sides in one blocked solve: the exact solution of the discrete
// sensitivity equation, i.e. the derivative of CVODES's own BDF step map. The history, order and
// step-size bookkeeping of S stay CVODES's. A step whose J and gamma are those of the last
// factorisation (a reused Jacobian, an unchanged step size and order) reuses its factors: the
// same matrix, so the same solution.
//
// With sensitivity error control, the convergence test CVODES installs is called as an exact
// Newton iteration would call it: once with the whole correction, and, if that does not pass,
// once more with the zero update the exact solution leaves; so CVODES computes the norm of the
// correction for its error test as it always does. Without, the test (two weighted norms over all
// columns, whose results nothing would use) is skipped.
//
// Ownership: the solver owns its workspace (sized at creation); freed with SUNNonlinSolFree
// after the CVODES memory it was attached to. Solves never allocate (for n above ~120, Eigen's
// blocked LU and triangular solves take their packing buffers from the heap; see README) and
// never throw. Not thread-safe: one per integrator.
#pragma once

#include <sundials/sundials_context.h>
#include <sundials/sundials_nonlinearsolver.h>

#include <span>

namespace hvac_twin::plant {

// J = df/dx (n x n, column-major) at the state y; returns the model status (0 ok, > 0
// recoverable, < 0 fatal). *J must stay valid until the next call.
using StepJacobianFn = int (*)(void* owner, std::span<const double> y, const double** J);

// The solver for n states and ns sensitivities, asking owner for Jacobians through jacobian;
// error_control: the integrator has sensitivity error control on. Returns null if it cannot be
// allocated. Attach with CVodeSetNonlinearSolverSensStg.
SUNNonlinearSolver make_direct_sensitivity_solver(SUNContext ctx, sunindextype n, int ns,
                                                  bool error_control, StepJacobianFn jacobian,
                                                  void* owner);

// Direct solves since creation (one per sensitivity corrector call), for statistics.
long direct_sensitivity_solves(SUNNonlinearSolver s);

}  // namespace hvac_twin::plant
