// Run-time consistency of the filter: are the sigmas it publishes true? Each cycle's
// MeasurementReports carry, per measured point, the normalised innovation squared
// NIS = innovation^2 / S. For a consistent filter NIS ~ chi2(1), so the mean of k of them lies in
// the two-sided 95 % band [chi2_0.025(k) / k, chi2_0.975(k) / k] (exact quantiles,
// chi_square.hpp). A mean above the band says S is too small (model error, a sensor fault, or
// noise set too low); below it, S is too large (noise set too high).
//
// Which samples count: every *available* measurement (offered to the filter and tested against
// its gate), with its test ratio as computed, rejected or not. The gate rejects precisely the
// inconsistent samples; leaving them out would truncate chi2(1) and hide a filter whose sigmas
// are far too small. The price: one gross outlier lifts its point's mean for a whole window, so
// the share of the window's samples the gate rejected is reported beside the mean (an outlier:
// ~1/k; sigmas too small: many). A non-finite test ratio (S = 0) is left out entirely.
//
// The window is the last W cycles (ring buffers sized at construction). A cycle without an
// update is a skip(): it ages the window, adds nothing. (The daemon updates in every cycle,
// late or not.)
// Per point: k = the point's samples in the window. Over all points: the sum of a cycle's m
// scalar NIS has mean m (each has mean 1, whatever their correlation), and over the window the
// sum has mean K = the total number of samples, whatever m was in each cycle; the overall figure
// is that sum / K (so it reads like a point's: 1 when consistent) with the band of chi2(K) / K.
//
// A screening test, not an exact one: the band assumes independent samples, and successive NIS
// of a filter on a real plant are autocorrelated (the same model error persists for many
// cycles), as are the innovations of different points within a cycle (S's off-diagonal terms),
// both of which widen the true spread of the mean. A mean just outside the band means "look",
// far outside it means the sigmas are wrong.
//
// Pure library: no I/O, no clock. The constructor allocates and throws; add(), skip() and the
// accessors never allocate or throw. One thread drives an instance.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>
#include <vector>

#include "daemon/estimation/estimator.hpp"

namespace hvac_twin::est {

enum class ConsistencyVerdict : std::uint8_t {
  kInsufficientData,  // fewer than min_samples samples in the window
  kInBand,            // the mean NIS inside the 95 % band
  kHigh,              // above: S too small (model error or fault; sigmas too optimistic)
  kLow,               // below: S too large (sigmas too pessimistic)
};
std::string_view to_string(ConsistencyVerdict verdict);  // "insufficient data", "in band", ...

struct ConsistencyOptions {
  std::size_t window_cycles = 360;  // W, >= 1
  std::size_t min_samples = 30;     // fewer samples: no verdict; 1..window_cycles
};

// The window's figure of one point, or of all points.
struct ConsistencyFigure {
  std::size_t samples = 0;      // NIS samples in the window (K over all points)
  double mean_nis = 0.0;        // their mean; 0 without samples
  double band_low = 0.0;        // chi2_0.025(k) / k; 0 without samples
  double band_high = 0.0;       // chi2_0.975(k) / k; 0 without samples
  double rejected_share = 0.0;  // share of the samples the gate rejected, [0, 1]
  ConsistencyVerdict verdict = ConsistencyVerdict::kInsufficientData;
};

class ConsistencyMonitor {
 public:
  // Throws std::invalid_argument unless 1 <= min_samples <= window_cycles.
  ConsistencyMonitor(std::size_t points, const ConsistencyOptions& options);

  // One cycle's reports, slot i = point i (as Estimator::update fills them). Missing slots count
  // as unavailable, extra ones are ignored.
  void add(std::span<const MeasurementReport> reports) noexcept;
  // A cycle without an update.
  void skip() noexcept;

  [[nodiscard]] const ConsistencyFigure& point(std::size_t i) const { return figures_[i]; }
  [[nodiscard]] const ConsistencyFigure& overall() const { return figures_.back(); }
  [[nodiscard]] std::size_t points() const { return points_; }
  [[nodiscard]] std::size_t window_cycles() const { return window_; }
  [[nodiscard]] std::size_t cycles_in_window() const { return cycles_; }
  // The two-sided 95 % band of the mean of k independent chi2(1) variables. Uncached.
  static void band(std::size_t k, double& low, double& high) noexcept;

 private:
  static constexpr std::uint8_t kSample = 1, kRejected = 2;
  void push(std::span<const MeasurementReport> reports) noexcept;
  void recompute_sums() noexcept;
  void update_figures() noexcept;
  void fill(ConsistencyFigure& f, std::size_t k, double sum, std::size_t rejected, double low,
            double high) const noexcept;
  // The per-point band for k samples, from a table filled as k values first occur.
  void point_band(std::size_t k, double& low, double& high) noexcept;

  std::size_t points_, window_, min_samples_;
  std::size_t next_ = 0;    // ring slot of the next cycle
  std::size_t cycles_ = 0;  // cycles in the window, <= W
  std::size_t since_recompute_ = 0;
  std::vector<double> nis_;            // W x points, ring of cycles
  std::vector<std::uint8_t> flags_;    // W x points: kSample, kRejected
  std::vector<double> sum_;            // per point: sum of the NIS in the window
  std::vector<std::size_t> count_;     // per point: samples in the window
  std::vector<std::size_t> rejected_;  // per point: rejected samples in the window
  std::vector<double> band_table_;     // (W + 1) x 2, NaN until computed
  std::size_t overall_k_ = 0;          // the overall band's k, cached
  double overall_low_ = 0.0, overall_high_ = 0.0;
  std::vector<ConsistencyFigure> figures_;  // points, then the overall figure
};

}  // namespace hvac_twin::est
