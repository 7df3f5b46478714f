// Whether a filter's published sigma is true: accumulators for the estimation and leak
// benchmarks (issue 12, item 4).
//  - Quantity: an estimate against its truth with the sigma it was published with: mean
//    absolute (percentage) error, RMS of the normalised error z = (estimate - truth) / sigma
//    (1 for a true sigma) and the share of samples with |z| <= 2 (95 % for a true Gaussian
//    sigma; the aim is 90-98 %).
//  - Sensor: the time-averaged NIS of one measured point (1 for a consistent filter) and the
//    share of its available samples the gate rejected.
//  - chi2_band: the 95 % band of a time-averaged chi-square statistic of `dof` degrees of
//    freedom over `samples` samples (Wilson-Hilferty).
// Header-only; benchmarks only.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <string>
#include <utility>

namespace hvac_twin::bench {

// Wilson-Hilferty chi-square quantile at the standard-normal quantile z.
inline double chi2_quantile(double z, double dof) {
  const double a = 2.0 / (9.0 * dof);
  return dof * std::pow(1.0 - a + z * std::sqrt(a), 3.0);
}

// The 95 % band of the time average of a chi-square(dof) statistic over `samples` samples.
inline std::pair<double, double> chi2_band(double dof, double samples) {
  const double n = std::max(samples, 1.0);
  return {chi2_quantile(-1.96, n * dof) / n, chi2_quantile(1.96, n * dof) / n};
}

class Quantity {
 public:
  explicit Quantity(std::string name = {}) : name_(std::move(name)) {}

  void add(double estimate, double sigma, double truth) {
    if (!std::isfinite(estimate) || !std::isfinite(truth)) return;
    const double e = estimate - truth;
    ++n_;
    abs_ += std::abs(e);
    if (truth != 0.0) ape_ += std::abs(e / truth);
    const double z = sigma > 0.0 ? e / sigma : (e == 0.0 ? 0.0 : 1e9);
    z2_ += z * z;
    if (std::abs(z) <= 2.0) ++within_;
    bias_ += e;
  }

  [[nodiscard]] const std::string& name() const { return name_; }
  [[nodiscard]] long samples() const { return n_; }
  [[nodiscard]] double mae() const { return n_ ? abs_ / static_cast<double>(n_) : 0.0; }
  [[nodiscard]] double mape() const { return n_ ? ape_ / static_cast<double>(n_) : 0.0; }
  [[nodiscard]] double bias() const { return n_ ? bias_ / static_cast<double>(n_) : 0.0; }
  [[nodiscard]] double rms_z() const { return n_ ? std::sqrt(z2_ / static_cast<double>(n_)) : 0.0; }
  [[nodiscard]] double within_2sigma() const {
    return n_ ? static_cast<double>(within_) / static_cast<double>(n_) : 0.0;
  }

 private:
  std::string name_;
  long n_ = 0, within_ = 0;
  double abs_ = 0.0, ape_ = 0.0, z2_ = 0.0, bias_ = 0.0;
};

class Sensor {
 public:
  explicit Sensor(std::string name = {}) : name_(std::move(name)) {}

  void add(bool available, double test_ratio, bool rejected) {
    if (!available) return;
    ++n_;
    nis_ += test_ratio;
    if (rejected) ++rejected_;
  }

  [[nodiscard]] const std::string& name() const { return name_; }
  [[nodiscard]] long samples() const { return n_; }
  [[nodiscard]] double nis() const { return n_ ? nis_ / static_cast<double>(n_) : 0.0; }
  [[nodiscard]] double rejected_share() const {
    return n_ ? static_cast<double>(rejected_) / static_cast<double>(n_) : 0.0;
  }

 private:
  std::string name_;
  long n_ = 0, rejected_ = 0;
  double nis_ = 0.0;
};

}  // namespace hvac_twin::bench
