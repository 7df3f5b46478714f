// Gaussian PDF truncation (Simon & Simon, "Constrained Kalman filtering via density function
// truncation for turbofan engine health estimation", Int. J. Systems Science 41(2), 2010).
//
// A Gaussian N(x, P) restricted to the half-space a' x <= b has, along the direction a, the
// moments of a truncated normal; conditioning the Gaussian on that scalar gives the truncated
// mean and covariance of the whole vector:
//   s = a' x,  sigma^2 = a' P a,  c = (b - s) / sigma,  lambda = phi(c) / Phi(c)
//   E[s | s <= b]   = s - sigma lambda
//   Var[s | s <= b] = sigma^2 (1 - c lambda - lambda^2)
//   x+ = x + P a (E - s) / sigma^2,   P+ = P - P a a' P (sigma^2 - Var) / sigma^4
// Applied once per active constraint, in order.
//
// Pure functions; no allocation beyond the caller's vectors; no exceptions.
#pragma once

#include <Eigen/Core>

namespace hvac_twin::est {

// Moments of a standard normal truncated to (-inf, c]: mean and variance.
struct TruncatedMoments {
  double mean = 0.0;      // -lambda(c)
  double variance = 1.0;  // 1 - c lambda - lambda^2, in (0, 1]
};
TruncatedMoments truncated_standard_normal(double c);

// Truncates N(x, P) to a' x <= b in place. `pa` is workspace of size n. Returns false (and
// leaves x, P alone) if a' P a is not positive.
bool truncate_gaussian(Eigen::Ref<Eigen::VectorXd> x, Eigen::Ref<Eigen::MatrixXd> P,
                       const Eigen::Ref<const Eigen::VectorXd>& a, double b,
                       Eigen::Ref<Eigen::VectorXd> pa);

}  // namespace hvac_twin::est
