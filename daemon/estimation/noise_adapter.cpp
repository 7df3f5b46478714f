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
      samples_(points, 0) {}

void NoiseAdapter::observe(std::span<const Measurement> z,
                           std::span<const MeasurementReport> reports,
                           std::span<const double> told) {
  const std::size_t count = std::min({z.size(), reports.size(), told.size(), factor_.size()});
  for (std::size_t i = 0; i < count; ++i) {
    const MeasurementReport& r = reports[i];
    const double s = r.innovation_variance;
    if (!r.available || r.faulty || !(s > 0.0) || !std::isfinite(r.innovation) || !std::isfinite(s))
      continue;
    if (!(told[i] > 0.0)) continue;
    const double hph = std::max(0.0, s - z[i].variance);  // the prior's part of S
    const double nu2 = std::min(r.innovation * r.innovation, options_.clip * s);
    const double w = (told[i] / s) * (told[i] / s);
    weight_[i] = keep_ * weight_[i] + w;
    weighted_r_[i] = keep_ * weighted_r_[i] + w * (nu2 - hph);
    if (++samples_[i] < options_.min_samples) continue;
    const double ratio = weighted_r_[i] / weight_[i] / told[i];
    factor_[i] = std::clamp(ratio, options_.min_factor, options_.max_factor);
  }
}

double NoiseAdapter::told_test_ratio(const MeasurementReport& r, double used, double told) {
  const double s = r.innovation_variance - used + told;
  return s > 0.0 ? r.innovation * r.innovation / s : r.test_ratio;
}

}  // namespace hvac_twin::est
