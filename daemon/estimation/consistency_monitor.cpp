#include "daemon/estimation/consistency_monitor.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "daemon/estimation/chi_square.hpp"

namespace hvac_twin::est {

std::string_view to_string(ConsistencyVerdict verdict) {
  switch (verdict) {
    case ConsistencyVerdict::kInsufficientData:
      return "insufficient data";
    case ConsistencyVerdict::kInBand:
      return "in band";
    case ConsistencyVerdict::kHigh:
      return "high";
    case ConsistencyVerdict::kLow:
      return "low";
  }
  return "unknown";
}

ConsistencyMonitor::ConsistencyMonitor(std::size_t points, const ConsistencyOptions& options)
    : points_(points), window_(options.window_cycles), min_samples_(options.min_samples) {
  if (window_ == 0 || min_samples_ == 0 || min_samples_ > window_)
    throw std::invalid_argument(
        "consistency monitor: needs 1 <= min_samples <= window_cycles (got " +
        std::to_string(min_samples_) + " and " + std::to_string(window_) + ")");
  nis_.assign(window_ * points_, 0.0);
  flags_.assign(window_ * points_, 0);
  sum_.assign(points_, 0.0);
  count_.assign(points_, 0);
  rejected_.assign(points_, 0);
  band_table_.assign(2 * (window_ + 1), std::numeric_limits<double>::quiet_NaN());
  figures_.resize(points_ + 1);
}

void ConsistencyMonitor::band(std::size_t k, double& low, double& high) noexcept {
  if (k == 0) {
    low = high = 0.0;
    return;
  }
  const double dof = static_cast<double>(k);
  low = chi_square_quantile(dof, 0.025) / dof;
  high = chi_square_quantile(dof, 0.975) / dof;
}

void ConsistencyMonitor::point_band(std::size_t k, double& low, double& high) noexcept {
  double* entry = &band_table_[2 * k];  // k <= W: a point has at most one sample per cycle
  if (std::isnan(entry[0])) band(k, entry[0], entry[1]);
  low = entry[0];
  high = entry[1];
}

void ConsistencyMonitor::add(std::span<const MeasurementReport> reports) noexcept {
  push(reports);
}

void ConsistencyMonitor::skip() noexcept {
  push({});
}

void ConsistencyMonitor::push(std::span<const MeasurementReport> reports) noexcept {
  double* nis = &nis_[next_ * points_];
  std::uint8_t* flags = &flags_[next_ * points_];
  const bool evict = cycles_ == window_;
  for (std::size_t i = 0; i < points_; ++i) {
    if (evict && (flags[i] & kSample) != 0) {  // the oldest cycle leaves the window
      sum_[i] = std::max(0.0, sum_[i] - nis[i]);
      --count_[i];
      if ((flags[i] & kRejected) != 0) --rejected_[i];
    }
    flags[i] = 0;
    nis[i] = 0.0;
    if (i >= reports.size()) continue;
    const MeasurementReport& r = reports[i];
    if (!r.available || !std::isfinite(r.test_ratio) || r.test_ratio < 0.0) continue;
    flags[i] = static_cast<std::uint8_t>(kSample | (r.rejected ? kRejected : 0));
    nis[i] = r.test_ratio;
    sum_[i] += r.test_ratio;
    ++count_[i];
    if (r.rejected) ++rejected_[i];
  }
  if (!evict) ++cycles_;
  next_ = (next_ + 1) % window_;
  // Subtracting what leaves the window accumulates rounding (a 1e9 outlier leaves ~1e-7 behind):
  // the sums start afresh from the ring once per window, O(points) per cycle on average.
  if (++since_recompute_ >= window_) recompute_sums();
  update_figures();
}

void ConsistencyMonitor::recompute_sums() noexcept {
  since_recompute_ = 0;
  std::fill(sum_.begin(), sum_.end(), 0.0);
  for (std::size_t c = 0; c < cycles_; ++c)
    for (std::size_t i = 0; i < points_; ++i)
      if ((flags_[c * points_ + i] & kSample) != 0) sum_[i] += nis_[c * points_ + i];
}

void ConsistencyMonitor::fill(ConsistencyFigure& f, std::size_t k, double sum, std::size_t rejected,
                              double low, double high) const noexcept {
  const double n = static_cast<double>(k);
  f.samples = k;
  f.mean_nis = k > 0 ? sum / n : 0.0;
  f.band_low = low;
  f.band_high = high;
  f.rejected_share = k > 0 ? static_cast<double>(rejected) / n : 0.0;
  f.verdict = k < min_samples_    ? ConsistencyVerdict::kInsufficientData
              : f.mean_nis > high ? ConsistencyVerdict::kHigh
              : f.mean_nis < low  ? ConsistencyVerdict::kLow
                                  : ConsistencyVerdict::kInBand;
}

void ConsistencyMonitor::update_figures() noexcept {
  std::size_t total = 0, total_rejected = 0;
  double total_sum = 0.0;
  for (std::size_t i = 0; i < points_; ++i) {
    double low = 0.0, high = 0.0;
    point_band(count_[i], low, high);
    fill(figures_[i], count_[i], sum_[i], rejected_[i], low, high);
    total += count_[i];
    total_sum += sum_[i];
    total_rejected += rejected_[i];
  }
  if (total != overall_k_) {  // K changes while the window fills, or with availability
    overall_k_ = total;
    band(total, overall_low_, overall_high_);
  }
  fill(figures_.back(), total, total_sum, total_rejected, overall_low_, overall_high_);
}

}  // namespace hvac_twin::est
