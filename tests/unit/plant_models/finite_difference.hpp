// Central finite differences, for checking exact derivatives in tests (never used by the filter).
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <span>
#include <vector>

namespace hvac_twin::test {

// Jacobian (m x n, column-major) of fn: R^n -> R^m at x, with relative step `rel` on each
// component (absolute step rel * max(|x_j|, floor_j)).
inline std::vector<double> central_jacobian(
    const std::function<void(std::span<const double>, std::span<double>)>& fn,
    std::span<const double> x, std::size_t m, std::span<const double> floor, double rel = 1e-6) {
  const std::size_t n = x.size();
  std::vector<double> jac(m * n), xp(x.begin(), x.end()), fp(m), fm(m);
  for (std::size_t j = 0; j < n; ++j) {
    const double h = rel * std::max(std::abs(x[j]), floor[j]);
    xp[j] = x[j] + h;
    fn(xp, fp);
    xp[j] = x[j] - h;
    fn(xp, fm);
    xp[j] = x[j];
    for (std::size_t i = 0; i < m; ++i)
      jac[j * m + i] = (fp[i] - fm[i]) / (2.0 * h);
  }
  return jac;
}

// Largest |a - b| / (|b| + abs_floor) over all entries.
inline double max_rel_error(std::span<const double> a, std::span<const double> b,
                            double abs_floor) {
  double worst = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i)
    worst = std::max(worst, std::abs(a[i] - b[i]) / (std::abs(b[i]) + abs_floor));
  return worst;
}

}  // namespace hvac_twin::test
