// How far a state-transition matrix F is from a reference, the way the integrator weighs the
// states: on the dimensionless D^-1 F D, D = diag(scale), each state in units of its resolution
// scale (abs_tol / rel_tol). For sensitivity_test, filter_transition_test and race_bench.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <span>

namespace hvac_twin::test {

struct TransitionError {
  double relative = 0.0;  // ||D^-1 (F - Fref) D|| / ||D^-1 Fref D||, Frobenius
  double worst = 0.0;     // largest entry error relative to the largest entry of its column
};

// F and Fref n x n, column-major; scale n entries.
inline TransitionError transition_error(std::span<const double> F, std::span<const double> Fref,
                                        std::span<const double> scale) {
  const std::size_t n = scale.size();
  double num = 0.0, den = 0.0, worst = 0.0;
  for (std::size_t c = 0; c < n; ++c) {
    double col = 0.0, err = 0.0;
    for (std::size_t r = 0; r < n; ++r) {
      const double w = scale[c] / scale[r];
      const double d = (F[c * n + r] - Fref[c * n + r]) * w, ref = Fref[c * n + r] * w;
      num += d * d;
      den += ref * ref;
      col = std::max(col, std::abs(ref));
      err = std::max(err, std::abs(d));
    }
    worst = std::max(worst, err / std::max(col, 1e-300));
  }
  return {std::sqrt(num / std::max(den, 1e-300)), worst};
}

}  // namespace hvac_twin::test
