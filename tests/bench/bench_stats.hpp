// Statistics of the series the benchmarks print: percentiles of times, and the moments a
// sequential test's design assumes. Header-only; benchmarks only (copies freely).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace hvac_twin::bench {

// The p-quantile (0 <= p <= 1) by nearest rank; 0 for an empty series.
inline double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  const auto k = static_cast<std::size_t>(p * static_cast<double>(v.size() - 1) + 0.5);
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

// Mean, sample standard deviation, lag-1 autocorrelation and largest value of a series.
struct SeriesStats {
  std::size_t n = 0;
  double mean = 0.0, sd = 0.0, r1 = 0.0, max = 0.0;
};

inline SeriesStats series_stats(const std::vector<double>& v) {
  SeriesStats st;
  st.n = v.size();
  if (v.empty()) return st;
  const double n = static_cast<double>(v.size());
  st.max = *std::max_element(v.begin(), v.end());
  for (const double x : v)
    st.mean += x / n;
  double var = 0.0, cov = 0.0;
  for (std::size_t i = 0; i < v.size(); ++i) {
    var += (v[i] - st.mean) * (v[i] - st.mean);
    if (i > 0) cov += (v[i] - st.mean) * (v[i - 1] - st.mean);
  }
  st.sd = std::sqrt(var / std::max(n - 1.0, 1.0));
  st.r1 = var > 0.0 ? cov / var : 0.0;
  return st;
}

}  // namespace hvac_twin::bench
