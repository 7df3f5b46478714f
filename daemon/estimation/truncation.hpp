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
// Depth limit. Far beyond the bound (c << 0) the truncated variance tends to sigma^2 / c^2: a
// posterior whose mean lies 5 sigma outside keeps 3 % of its variance along a. That is what a
// Gaussian's tail says, but a posterior that puts 3e-7 of its mass on the feasible side is far
// likelier wrong (a grossly wrong reading fused, an update linearised far from where it landed)
// than right, and the tail shape is the part of it least to be trusted. Truncated as if its mean
// were at most `max_depth` sigma outside (c >= -max_depth), the constraint still removes what a
// modest violation says (c = -1: the variance along a to 0.20 sigma^2) without turning an
// outlier into certainty. Seen on the heat pump (constraints_heat_pump_test, F exact): a
// suction-sensor glitch fused with the gate open drove the charge 15 sigma above its bound;
// truncated fully, its sigma fell from 3.8 g to 0.7 g with the estimate 100 g off, and 60
// cycles later the high side was still 21-29 g off; with the limit at 1 sigma, within 0.2 g.
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

// Truncates N(x, P) to a' x <= b in place, at most max_depth sigma deep (see above; infinity:
// the exact truncated moments). `pa` is workspace of size n. Returns false (and leaves x, P
// alone) if a' P a is not positive.
bool truncate_gaussian(Eigen::Ref<Eigen::VectorXd> x, Eigen::Ref<Eigen::MatrixXd> P,
                       const Eigen::Ref<const Eigen::VectorXd>& a, double b,
                       Eigen::Ref<Eigen::VectorXd> pa, double max_depth);

}  // namespace hvac_twin::est
