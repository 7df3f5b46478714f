// Bounded covariance matching of the measurement noise, per measured point (Mehra 1972; Myers
// and Tapley 1976): for a filter whose prior is right, an innovation has variance
// E[nu^2] = H P- H' + R, so R_hat = mean(nu^2) - mean(H P- H') estimates the noise the point
// really shows: its sensor noise plus what the model cannot represent at that sensor (its cells,
// its closures, a bias). The filter is then told
//
//     R_i = told_i * f_i,   f_i = clamp(R_hat_i / told_i, min_factor, max_factor),
//
// once a point has min_samples samples (before: f_i = 1). With min_factor = 1 the told noise is a
// floor (the installer's figure for the sensor); max_factor bounds what a fault can buy.
//
// R_hat is a weighted mean of the samples' nu^2 - H P- H', exponentially forgotten over
// window_cycles, each weighted by (told / S)^2: a sample's information about R (the variance of
// nu^2 is 2 S^2), so that the innovations of a wide prior (a cold start, a covariance reset,
// where S is all prior and says nothing of the sensor) barely count. The samples are those the
// filter tested, rejected or not: a sample the gate rejected enters with nu^2
// clipped at clip * S (a gross outlier moves R by a bounded step, a persistent misfit by many);
// points reported `faulty` (rejected max_consecutive_rejections times in a row) are left out: a
// transmitter gone wrong is a fault for the lost-track and stuck checks to report, not noise to
// learn. Nor is a filter that has lost track (most points gated out, est::TrackMonitor): its
// innovations measure its own error, not the sensors'. A loss of track is declared only after
// some updates, so each update's samples are held `hold_updates` updates before they count, and
// the caller discards what is held (discard_held) when it finds the track lost, the covariance
// reset or the filter restarted, and leaves those updates out. Adapting hides nothing: the
// consistency monitor judges the innovations against the told noise (told_test_ratio), so a point
// that needs its noise inflated still shows HIGH.
//
// Pure library: no I/O, no clock. The constructor allocates; the rest never allocates or throws.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "daemon/estimation/estimator.hpp"

namespace hvac_twin::est {

struct NoiseAdapterOptions {
  std::size_t window_cycles = 720;
  std::size_t min_samples = 60;
  double min_factor = 1.0;  // (0, 1]
  double max_factor = 1.0;  // [1, ...); min = max = 1: no adaptation
  double clip = 10.83;      // a rejected sample's nu^2 counts at most clip * S (the filter's gate)
  std::size_t hold_updates = 0;  // an update's samples count this many updates later
};

class NoiseAdapter {
 public:
  NoiseAdapter(std::size_t points, const NoiseAdapterOptions& options);

  // The variance to tell the filter for point i whose told variance is `told`.
  [[nodiscard]] double variance(std::size_t i, double told) const { return told * factor_[i]; }
  [[nodiscard]] double factor(std::size_t i) const { return factor_[i]; }

  // After an update: the measurements as offered (their variances as told to the filter, i.e.
  // variance() of the told ones) and the filter's reports, point by point; `told` the told
  // variances. Updates the factors.
  void observe(std::span<const Measurement> z, std::span<const MeasurementReport> reports,
               std::span<const double> told);
  // Forgets the samples still held: the updates they came from are not to be learnt from.
  void discard_held();

  // A report's test ratio against the told noise instead of the adapted one.
  static double told_test_ratio(const MeasurementReport& r, double used, double told);

 private:
  NoiseAdapterOptions options_;
  double keep_;                              // 1 - 1 / window_cycles
  std::vector<double> weight_, weighted_r_;  // forgotten sums of w and of w (nu^2 - H P- H')
  std::vector<double> factor_;
  std::vector<std::size_t> samples_;
  // The held samples, a ring of hold_updates updates of one entry per point: w and
  // w (nu^2 - H P- H'), w < 0 for a point that gave no sample.
  struct Held {
    double w, wr;
  };
  std::vector<Held> held_;
  std::size_t held_updates_ = 0, held_next_ = 0;  // filled slots; the slot the next update takes

  void learn(std::size_t i, double told, Held sample);
};

}  // namespace hvac_twin::est
