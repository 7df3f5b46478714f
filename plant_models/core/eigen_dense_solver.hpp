// A direct SUNLinearSolver for SUNDIALS dense matrices backed by Eigen's partial-pivoting LU:
// the same algorithm as SUNLinSol_Dense, with blocked factorisation and vectorised triangular
// solves. With forward sensitivities CVODES solves one system per sensitivity per corrector
// iteration (about 80 per step on the 48-state heat pump), where SUNDIALS' generic dense
// solve dominated the profile. Private to the integrator.
//
// The solver owns its workspace (sized at creation); setup and solve never allocate.
#pragma once

#include <sundials/sundials_context.h>
#include <sundials/sundials_linearsolver.h>

namespace hvac_twin::plant {

// An n x n solver, freed with SUNLinSolFree.
SUNLinearSolver make_eigen_dense_solver(SUNContext ctx, sunindextype n);

}  // namespace hvac_twin::plant
