#include "daemon/estimation/chi_square.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hvac_twin::est {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kEpsilon = 1e-16;
constexpr int kMaxIterations = 200000;  // sqrt(a)-like; enough for a = 1e9

// ln Gamma(a), a > 0: Stirling's series from a >= 10 (error below 2e-14), shifted up to there by
// Gamma(a + 1) = a Gamma(a).
double log_gamma(double a) {
  double product = 1.0;
  while (a < 10.0) {
    product *= a;
    a += 1.0;
  }
  const double inv = 1.0 / a;
  const double inv2 = inv * inv;
  const double series =
      inv * (1.0 / 12.0 -
             inv2 * (1.0 / 360.0 - inv2 * (1.0 / 1260.0 - inv2 * (1.0 / 1680.0 - inv2 / 1188.0))));
  constexpr double kHalfLog2Pi = 0.91893853320467274178;
  return (a - 0.5) * std::log(a) - a + kHalfLog2Pi + series - std::log(product);
}

// The regularized lower incomplete gamma function P(a, x), a > 0, x > 0.
double gamma_p(double a, double x) {
  const double log_prefix = a * std::log(x) - x - log_gamma(a);
  if (x < a + 1.0) {  // the series converges fast here
    double term = 1.0 / a, sum = term, ap = a;
    for (int n = 0; n < kMaxIterations; ++n) {
      ap += 1.0;
      term *= x / ap;
      sum += term;
      if (term < sum * kEpsilon) break;
    }
    return std::min(1.0, sum * std::exp(log_prefix));
  }
  // Q(a, x) by the continued fraction (modified Lentz), P = 1 - Q.
  constexpr double kTiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / kTiny, d = 1.0 / b, h = d;
  for (int i = 1; i < kMaxIterations; ++i) {
    const double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::abs(d) < kTiny) d = kTiny;
    c = b + an / c;
    if (std::abs(c) < kTiny) c = kTiny;
    d = 1.0 / d;
    const double delta = d * c;
    h *= delta;
    if (std::abs(delta - 1.0) < kEpsilon) break;
  }
  return std::max(0.0, 1.0 - std::exp(log_prefix) * h);
}

}  // namespace

double chi_square_cdf(double k, double x) noexcept {
  if (!(k > 0.0) || std::isnan(x)) return kNaN;
  if (x <= 0.0) return 0.0;
  if (std::isinf(x)) return 1.0;
  return gamma_p(0.5 * k, 0.5 * x);
}

double chi_square_quantile(double k, double p) noexcept {
  if (!(k > 0.0) || !(p > 0.0 && p < 1.0) || std::isinf(k)) return kNaN;
  // Solve P(a, y) = p for y = x / 2 inside a bracket [lo, hi] that always holds the root.
  const double a = 0.5 * k;
  double lo = 0.0, hi = std::max(1.0, a);
  while (gamma_p(a, hi) < p) {
    lo = hi;
    hi *= 2.0;
  }
  const double log_norm = log_gamma(a);
  double y = std::clamp(a, lo, hi);  // the mean: Newton needs few steps from there
  if (!(y > lo && y < hi)) y = 0.5 * (lo + hi);
  for (int i = 0; i < 500; ++i) {
    const double f = gamma_p(a, y) - p;
    if (f == 0.0) break;
    (f < 0.0 ? lo : hi) = y;
    const double density = std::exp((a - 1.0) * std::log(y) - y - log_norm);
    double next = y - f / density;
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);  // Newton left the bracket: bisect
    const bool converged = std::abs(next - y) <= 1e-13 * next || hi - lo <= 1e-13 * hi;
    y = next;
    if (converged) break;
  }
  return 2.0 * y;
}

}  // namespace hvac_twin::est
