// The chi-square distribution: its distribution function and its exact inverse, for the bands of
// the filter-consistency monitor (consistency_monitor.hpp).
//
// Exact, not the Wilson-Hilferty approximation: that one is 0.7 % off at 10 degrees of freedom
// and useless below about 3 (its lower 2.5 % point of chi2(1) comes out negative), and a window
// may hold that few samples. The distribution function is the regularized incomplete gamma
// function P(k/2, x/2) (series below the mean, Lentz's continued fraction above it; Numerical
// Recipes 6.2), with a Stirling-series log-gamma of our own: std::lgamma writes the global
// `signgam` and is not safe to call from several unit threads at once.
//
// Pure functions: no allocation, no exceptions, any thread. Cost grows like sqrt(k) iterations
// (about 2000 at k = 1e7), so callers cache quantiles they need every cycle.
#pragma once

namespace hvac_twin::est {

// P(X <= x) for X ~ chi2(k). k > 0; 0 for x <= 0; NaN for k <= 0 or a NaN argument.
double chi_square_cdf(double k, double x) noexcept;

// The p-quantile of chi2(k): x with chi_square_cdf(k, x) = p, to a relative 1e-12. k > 0 and
// 0 < p < 1, else NaN. Newton's method on the distribution function, kept inside a bracket
// by bisection.
double chi_square_quantile(double k, double p) noexcept;

}  // namespace hvac_twin::est
