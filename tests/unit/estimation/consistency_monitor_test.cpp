// The filter-consistency monitor: its chi-square bands against tabulated quantiles and against an
// independent numerical integration of the density, and its verdicts on simulated NIS streams
// of known variance (consistent, sigma too small, sigma too large), window eviction, the
// rejected share and the overall figure with a varying number of points per cycle.
#include "daemon/estimation/consistency_monitor.hpp"

#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <vector>

#include "daemon/estimation/chi_square.hpp"

using namespace hvac_twin::est;

namespace {

// P(X <= x) for X ~ chi2(k) by Simpson's rule on the density, in u = sqrt(t) so that the
// t^(k/2 - 1) singularity of k = 1 at 0 goes away: integrand 2 u^(k-1) e^(-u^2/2) / norm.
// Independent of chi_square.cpp (no incomplete gamma function, std::lgamma for the norm).
double cdf_by_integration(double k, double x) {
  const double log_norm = 0.5 * k * std::log(2.0) + std::lgamma(0.5 * k);
  const double top = std::sqrt(x);
  const int n = 20000;  // even
  const double h = top / n;
  const auto f = [&](double u) {
    if (u == 0.0) return k == 1.0 ? 2.0 * std::exp(-log_norm) : 0.0;
    return 2.0 * std::exp((k - 1.0) * std::log(u) - 0.5 * u * u - log_norm);
  };
  double sum = f(0.0) + f(top);
  for (int i = 1; i < n; ++i)
    sum += (i % 2 == 1 ? 4.0 : 2.0) * f(i * h);
  return sum * h / 3.0;
}

// A report of one available measurement with the given NIS.
MeasurementReport sample(double nis, bool rejected = false) {
  MeasurementReport r;
  r.available = true;
  r.test_ratio = nis;
  r.rejected = rejected;
  r.fused = !rejected;
  return r;
}

// Feeds `cycles` cycles of one point with NIS = (sigma z)^2, z ~ N(0, 1): a filter whose true
// innovation spread is sigma times the one it reports.
void feed(ConsistencyMonitor& m, std::mt19937_64& rng, double sigma, int cycles) {
  std::normal_distribution<double> g(0.0, sigma);
  for (int c = 0; c < cycles; ++c) {
    const double v = g(rng);
    const MeasurementReport r = sample(v * v, v * v > 10.83);
    m.add(std::span<const MeasurementReport>(&r, 1));
  }
}

}  // namespace

TEST_CASE("chi-square quantiles match the tables and the integrated density", "[consistency]") {
  // Two-sided 95 % points. Printed tables give k = 1, 2, 10 to five decimals (0.00098 / 5.02389,
  // 0.05064 / 7.37776, 3.24697 / 20.48318) and k = 100 to three (NIST/SEMATECH e-Handbook
  // 1.3.6.7.4: 74.222 / 129.561); these digits, and k = 1000, by bisection on mpmath's
  // regularized incomplete gamma function at 30 digits.
  struct Row {
    double k, low, high;
  };
  for (const Row& row :
       {Row{1, 0.000982069, 5.023886}, Row{2, 0.0506356, 7.377759}, Row{10, 3.246973, 20.483177},
        Row{100, 74.221927, 129.561197}, Row{1000, 914.257154, 1089.530913}}) {
    INFO("k = " << row.k);
    CHECK(chi_square_quantile(row.k, 0.025) == Approx(row.low).epsilon(1e-6));
    CHECK(chi_square_quantile(row.k, 0.975) == Approx(row.high).epsilon(1e-6));
  }
  // The inverse inverts the distribution function as an independent integration computes it.
  for (const double k : {1.0, 3.0, 7.0, 30.0, 360.0}) {
    for (const double p : {0.025, 0.5, 0.975}) {
      INFO("k = " << k << ", p = " << p);
      const double x = chi_square_quantile(k, p);
      CHECK(cdf_by_integration(k, x) == Approx(p).epsilon(1e-7));
      CHECK(chi_square_cdf(k, x) == Approx(p).epsilon(1e-12));
    }
  }
  // Large k (a window over all points) stays accurate: the quantile tends to k + z sqrt(2k).
  const double k = 1e6;
  CHECK(chi_square_quantile(k, 0.975) == Approx(k + 1.959964 * std::sqrt(2.0 * k)).epsilon(1e-5));
  CHECK(std::isnan(chi_square_quantile(0.0, 0.5)));
  CHECK(std::isnan(chi_square_quantile(3.0, 1.0)));
  CHECK(chi_square_cdf(3.0, -1.0) == 0.0);
}

TEST_CASE("the band of the mean NIS is chi2(k) / k, as README says for N = 1000", "[consistency]") {
  double low = 0.0, high = 0.0;
  ConsistencyMonitor::band(1000, low, high);
  CHECK(low == Approx(0.914257).epsilon(1e-6));
  CHECK(high == Approx(1.089531).epsilon(1e-6));
  ConsistencyMonitor::band(10, low, high);
  CHECK(low == Approx(0.3246973).epsilon(1e-6));
  CHECK(high == Approx(2.0483177).epsilon(1e-6));
  ConsistencyMonitor::band(0, low, high);
  CHECK(low == 0.0);
  CHECK(high == 0.0);
}

TEST_CASE("a consistent stream is in band, variance 4 is high, 0.25 is low", "[consistency]") {
  struct Case {
    double sigma;
    ConsistencyVerdict expected;
  };
  for (const Case c : {Case{1.0, ConsistencyVerdict::kInBand}, Case{2.0, ConsistencyVerdict::kHigh},
                       Case{0.5, ConsistencyVerdict::kLow}}) {
    ConsistencyMonitor m(1, ConsistencyOptions{.window_cycles = 500, .min_samples = 30});
    std::mt19937_64 rng(1);  // a consistent window is in band with probability 0.95 (checked
                             // below): this seed's is, the test is deterministic
    feed(m, rng, c.sigma, 29);
    INFO("sigma " << c.sigma);
    CHECK(m.point(0).verdict == ConsistencyVerdict::kInsufficientData);  // 29 < min_samples
    feed(m, rng, c.sigma, 1000);
    const ConsistencyFigure& f = m.point(0);
    INFO("mean NIS " << f.mean_nis << " in [" << f.band_low << ", " << f.band_high << "]");
    CHECK(f.samples == 500);  // the window, not everything seen
    CHECK(f.band_low == Approx(chi_square_quantile(500, 0.025) / 500));
    CHECK(f.mean_nis == Approx(c.sigma * c.sigma).epsilon(0.15));
    CHECK(f.verdict == c.expected);
    CHECK(m.overall().verdict == c.expected);  // one point: the same figure
    CHECK(m.overall().mean_nis == Approx(f.mean_nis));
  }
}

TEST_CASE("a consistent stream is in band about 95 % of the time", "[consistency]") {
  // The band's coverage: 400 independent windows of 100 samples from one seed.
  std::mt19937_64 rng(7);
  int in_band = 0;
  for (int w = 0; w < 400; ++w) {
    ConsistencyMonitor m(1, ConsistencyOptions{.window_cycles = 100, .min_samples = 100});
    feed(m, rng, 1.0, 100);
    if (m.point(0).verdict == ConsistencyVerdict::kInBand) ++in_band;
  }
  INFO(in_band << " of 400 windows in band");
  CHECK(in_band >= 368);  // 95 % of 400 = 380, binomial sigma 4.4: within 2.7 sigma
  CHECK(in_band <= 392);
}

TEST_CASE("old samples leave the window and skipped cycles age it", "[consistency]") {
  ConsistencyMonitor m(1, ConsistencyOptions{.window_cycles = 10, .min_samples = 5});
  const MeasurementReport big = sample(100.0), one = sample(1.0);
  m.add(std::span<const MeasurementReport>(&big, 1));
  for (int i = 0; i < 9; ++i)
    m.add(std::span<const MeasurementReport>(&one, 1));
  CHECK(m.point(0).samples == 10);
  CHECK(m.point(0).mean_nis == Approx(10.9));
  CHECK(m.point(0).verdict == ConsistencyVerdict::kHigh);
  m.add(std::span<const MeasurementReport>(&one, 1));  // the outlier leaves
  CHECK(m.point(0).samples == 10);
  CHECK(m.point(0).mean_nis == Approx(1.0));
  CHECK(m.point(0).verdict == ConsistencyVerdict::kInBand);
  for (int i = 0; i < 6; ++i)
    m.skip();  // no update: the window moves on without samples
  CHECK(m.cycles_in_window() == 10);
  CHECK(m.point(0).samples == 4);
  CHECK(m.point(0).verdict == ConsistencyVerdict::kInsufficientData);
  for (int i = 0; i < 4; ++i)
    m.skip();
  CHECK(m.point(0).samples == 0);
  CHECK(m.point(0).mean_nis == 0.0);
  CHECK(m.point(0).band_high == 0.0);
  // Many windows of add and evict: the running sum does not drift (it starts afresh per window).
  // (Thirds: adding one to 1e12 rounds, so subtracting the 1e12 again leaves ~1e-4 behind.)
  const MeasurementReport huge = sample(1e12), third = sample(1.0 / 3.0);
  for (int i = 0; i < 1000; ++i)
    m.add(std::span<const MeasurementReport>(i % 7 == 0 ? &huge : &third, 1));
  for (int i = 0; i < 11; ++i)
    m.add(std::span<const MeasurementReport>(&third, 1));
  CHECK(m.point(0).mean_nis == Approx(1.0 / 3.0).epsilon(1e-13));
}

TEST_CASE("the rejected share, unavailable and non-finite samples", "[consistency]") {
  ConsistencyMonitor m(2, ConsistencyOptions{.window_cycles = 20, .min_samples = 10});
  MeasurementReport off;  // not available: not a sample
  off.test_ratio = 50.0;
  MeasurementReport nan = sample(std::nan(""), true);  // S = 0: left out
  for (int i = 0; i < 20; ++i) {
    const MeasurementReport cycle[] = {i % 4 == 0 ? sample(16.0, true) : sample(0.5),
                                       i % 2 == 0 ? off : nan};
    m.add(cycle);
  }
  const ConsistencyFigure& a = m.point(0);
  CHECK(a.samples == 20);
  CHECK(a.rejected_share == Approx(0.25));
  CHECK(a.mean_nis == Approx((5 * 16.0 + 15 * 0.5) / 20.0));  // rejected ones count, as computed
  CHECK(m.point(1).samples == 0);
  CHECK(m.point(1).rejected_share == 0.0);
  CHECK(m.point(1).verdict == ConsistencyVerdict::kInsufficientData);
  CHECK(m.overall().samples == 20);
  CHECK(m.overall().rejected_share == Approx(0.25));
  // Fewer reports than points: the missing ones are unavailable.
  const MeasurementReport only_first[] = {sample(1.0)};
  m.add(only_first);
  CHECK(m.point(1).samples == 0);
}

TEST_CASE("the overall figure pools every sample: degrees of freedom vary per cycle",
          "[consistency]") {
  // Three points; point 2 is available only every third cycle and point 1 never in the first
  // half. Over the window the sum of all NIS is chi2(K), K the number of samples.
  ConsistencyMonitor m(3, ConsistencyOptions{.window_cycles = 300, .min_samples = 30});
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g;
  double sum = 0.0;
  std::size_t k = 0;
  for (int c = 0; c < 300; ++c) {
    MeasurementReport cycle[3];
    for (int i = 0; i < 3; ++i) {
      if ((i == 1 && c < 150) || (i == 2 && c % 3 != 0)) continue;
      const double v = g(rng);
      cycle[i] = sample(v * v);
      sum += v * v;
      ++k;
    }
    m.add(cycle);
  }
  const ConsistencyFigure& all = m.overall();
  CHECK(all.samples == k);
  CHECK(k == 300 + 150 + 100);
  CHECK(all.mean_nis == Approx(sum / static_cast<double>(k)));
  CHECK(all.band_low == Approx(chi_square_quantile(550, 0.025) / 550.0));
  CHECK(all.band_high == Approx(chi_square_quantile(550, 0.975) / 550.0));
  CHECK(all.verdict == ConsistencyVerdict::kInBand);
  CHECK(m.point(0).samples == 300);
  CHECK(m.point(1).samples == 150);
  CHECK(m.point(2).samples == 100);
  // One point far off lifts the pooled figure too.
  for (int c = 0; c < 300; ++c) {
    const MeasurementReport cycle[] = {sample(1.0), sample(1.0), sample(9.0)};
    m.add(cycle);
  }
  CHECK(m.point(2).verdict == ConsistencyVerdict::kHigh);
  CHECK(m.point(0).verdict == ConsistencyVerdict::kInBand);
  CHECK(m.overall().mean_nis == Approx(11.0 / 3.0));
  CHECK(m.overall().verdict == ConsistencyVerdict::kHigh);
}

TEST_CASE("the monitor refuses a window shorter than its minimum sample count", "[consistency]") {
  CHECK_THROWS_AS(ConsistencyMonitor(1, ConsistencyOptions{.window_cycles = 0, .min_samples = 1}),
                  std::invalid_argument);
  CHECK_THROWS_AS(ConsistencyMonitor(1, ConsistencyOptions{.window_cycles = 10, .min_samples = 11}),
                  std::invalid_argument);
  CHECK_NOTHROW(ConsistencyMonitor(0, ConsistencyOptions{.window_cycles = 1, .min_samples = 1}));
}
