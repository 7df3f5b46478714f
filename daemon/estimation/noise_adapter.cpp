#include "daemon/estimation/noise_adapter.hpp"

#include <algorithm>
#include <cmath>

namespace hvac_twin::est {

NoiseAdapter::NoiseAdapter(std::size_t points, const NoiseAdapterOptions& options)
    : options_(options),
      keep_(1.0 - 1.0 / static_cast<double>(std::max<std::size_t>(options.window_cycles, 1))),
      weight_(points, 0.0),
      weighted_r_(points, 0.0),
      factor_(points, 1.0),
      samples_(points, 0),
      held_(options.hold_updates * points, Held{-1.0, 0.0}) {}

void NoiseAdapter::observe(std::span<const Measurement> z,
                           std::span<const MeasurementReport> reports,
                           std::span<const double> told) {
  const std::size_t points = factor_.size();
  const std::size_t count = std::min({z.size(), reports.size(), told.size(), points});
  // This update's samples take the ring's next slot; the one held longest comes out of it.
  Held* slot = options_.hold_updates > 0 ? &held_[held_next_ * points] : nullptr;
  for (std::size_t i = 0; i < points; ++i) {
    Held sample{-1.0, 0.0};
    const MeasurementReport* r = i < count ? &reports[i] : nullptr;
    const double s = r != nullptr ? r->innovation_variance : 0.0;
    if (r != nullptr && r->available && !r->faulty && s > 0.0 && std::isfinite(r->innovation) &&
        std::isfinite(s) && told[i] > 0.0) {
      const double hph = std::max(0.0, s - z[i].variance);  // the prior's part of S
      const double nu2 = std::min(r->innovation * r->innovation, options_.clip * s);
      const double w = (told[i] / s) * (told[i] / s);
      sample = Held{w, w * (nu2 - hph)};
    }
    if (slot == nullptr) {
      if (i < count) learn(i, told[i], sample);
      continue;
    }
    if (held_updates_ == options_.hold_updates && i < count) learn(i, told[i], slot[i]);
    slot[i] = sample;
  }
  if (slot == nullptr) return;
  held_next_ = (held_next_ + 1) % options_.hold_updates;
  held_updates_ = std::min(held_updates_ + 1, options_.hold_updates);
}

void NoiseAdapter::discard_held() {
  held_updates_ = 0;
  held_next_ = 0;
}

void NoiseAdapter::learn(std::size_t i, double told, Held sample) {
  if (!(sample.w >= 0.0)) return;
  weight_[i] = keep_ * weight_[i] + sample.w;
  weighted_r_[i] = keep_ * weighted_r_[i] + sample.wr;
  if (++samples_[i] < options_.min_samples) return;
  const double ratio = weighted_r_[i] / weight_[i] / told;
  factor_[i] = std::clamp(ratio, options_.min_factor, options_.max_factor);
}

double NoiseAdapter::told_test_ratio(const MeasurementReport& r, double used, double told) {
  const double s = r.innovation_variance - used + told;
  return s > 0.0 ? r.innovation * r.innovation / s : r.test_ratio;
}

}  // namespace hvac_twin::est
