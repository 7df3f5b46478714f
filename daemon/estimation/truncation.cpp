#include "daemon/estimation/truncation.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace hvac_twin::est {

TruncatedMoments truncated_standard_normal(double c) {
  // lambda(c) = phi(c) / Phi(c), the inverse Mills ratio of the lower tail. Phi(c) =
  // erfc(-c/sqrt 2)/2 keeps full relative accuracy deep into the tail; 1 - c lambda - lambda^2
  // loses about log10(c^4) digits to cancellation, i.e. 10 significant digits remain at
  // c = -30. Below that the asymptotic series (terms of order c^-8 and smaller dropped).
  TruncatedMoments m;
  if (c > 40.0) return m;  // nothing truncated
  if (c < -30.0) {
    const double c2 = c * c;
    const double lambda = -c * (1.0 + 1.0 / c2 - 2.0 / (c2 * c2) + 10.0 / (c2 * c2 * c2));
    m.mean = -lambda;
    m.variance = (1.0 - 6.0 / c2 + 50.0 / (c2 * c2)) / c2;
    return m;
  }
  const double phi = std::exp(-0.5 * c * c) / std::sqrt(2.0 * std::numbers::pi);
  const double Phi = 0.5 * std::erfc(-c / std::numbers::sqrt2);
  const double lambda = phi / Phi;
  m.mean = -lambda;
  m.variance = 1.0 - c * lambda - lambda * lambda;
  return m;
}

bool truncate_gaussian(Eigen::Ref<Eigen::VectorXd> x, Eigen::Ref<Eigen::MatrixXd> P,
                       const Eigen::Ref<const Eigen::VectorXd>& a, double b,
                       Eigen::Ref<Eigen::VectorXd> pa, double max_depth) {
  pa.noalias() = P * a;
  const double var = a.dot(pa);
  if (!(var > 0.0)) return false;
  const double sigma = std::sqrt(var);
  const double s = a.dot(x);
  const TruncatedMoments t = truncated_standard_normal(std::max((b - s) / sigma, -max_depth));
  x += pa * (t.mean * sigma / var);
  const double shrink = (1.0 - t.variance) / var;  // (sigma^2 - Var) / sigma^4
  const auto n = P.rows();
  for (Eigen::Index c = 0; c < n; ++c)
    for (Eigen::Index r = 0; r < n; ++r)
      P(r, c) -= shrink * pa(r) * pa(c);
  return true;
}

}  // namespace hvac_twin::est
