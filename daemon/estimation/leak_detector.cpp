#include "daemon/estimation/leak_detector.hpp"

#include <algorithm>
#include <cmath>

namespace hvac_twin::est {

std::string_view to_string(LeakState state) {
  switch (state) {
    case LeakState::kNormal:
      return "NORMAL";
    case LeakState::kSuspect:
      return "SUSPECT";
    case LeakState::kLeak:
      return "LEAK";
  }
  return "UNKNOWN";
}

std::string_view to_string(HoldReason reason) {
  switch (reason) {
    case HoldReason::kNone:
      return "";
    case HoldReason::kWarmUp:
      return "warm-up";
    case HoldReason::kCompressorOff:
      return "compressor off";
    case HoldReason::kStartUp:
      return "compressor start-up";
    case HoldReason::kCycling:
      return "compressor cycling";
    case HoldReason::kDegraded:
      return "estimates degraded";
  }
  return "unknown";
}

double LeakDetector::arl0(double k, double h) {
  const double b = 2.0 * k * (h + 1.166);
  return (std::exp(b) - b - 1.0) / (2.0 * k * k);
}

namespace {

// The threshold whose in-control run length (Siegmund) is `decisions` for reference value k:
// ARL0 grows monotonically with h, so bisection.
double threshold_for(double k, double decisions) {
  double lo = 0.0, hi = 100.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (LeakDetector::arl0(k, mid) < decisions ? lo : hi) = mid;
  }
  return hi;
}

}  // namespace

LeakDetector::LeakDetector(const LeakDetectorOptions& options)
    : options_(options), k_(0.5 * options.design_shift_sigma) {
  // The designed time between false alarms, counted in decisions. Two statistics that may each
  // raise the alarm get twice the time each.
  const double statistics = options.charge_allowance > 0.0 ? 2.0 : 1.0;
  const double decisions =
      statistics * options.false_alarm_interval_days * 86400.0 / std::max(options.interval_s, 1.0);
  h_ = threshold_for(k_, decisions);
  report_.threshold = h_;
  charge_noise_ = options.charge_noise > 0.0 ? options.charge_noise : options.charge_allowance;
  if (options.charge_allowance > 0.0)
    charge_scale_ = h_ / threshold_for(options.charge_allowance / charge_noise_, decisions);
}

const LeakReport& LeakDetector::step(double t, double leak, double sigma, double compressor_hz,
                                     bool degraded) {
  return step_with(t, leak, sigma, std::nan(""), 0.0, compressor_hz, degraded, false);
}

const LeakReport& LeakDetector::step(double t, double leak, double sigma, double charge,
                                     double charge_sigma, double compressor_hz, bool degraded) {
  return step_with(t, leak, sigma, charge, charge_sigma, compressor_hz, degraded,
                   options_.charge_allowance > 0.0);
}

const LeakReport& LeakDetector::step_with(double t, double leak, double sigma, double charge,
                                          double charge_sigma, double compressor_hz, bool degraded,
                                          bool use_charge) {
  if (start_t_ < 0.0) start_t_ = t;
  const double dt = last_t_ < 0.0 ? 0.0 : std::max(0.0, t - last_t_);
  last_t_ = t;

  // Compressor starts, for start-up and cycling holds.
  const bool running = compressor_hz >= options_.min_compressor_speed_hz;
  if (running && !running_) {
    running_since_ = t;
    starts_[next_start_] = t;
    next_start_ = (next_start_ + 1) % 8;
    n_starts_ = std::min(n_starts_ + 1, 8);
  }
  running_ = running;
  int recent = 0;
  for (int i = 0; i < n_starts_; ++i)
    if (t - starts_[i] < 3600.0) ++recent;

  HoldReason hold = HoldReason::kNone;
  if (t - start_t_ < options_.warm_up_s)
    hold = HoldReason::kWarmUp;
  else if (!running)
    hold = HoldReason::kCompressorOff;
  else if (recent > options_.max_starts_per_hour)
    hold = HoldReason::kCycling;
  else if (t - running_since_ < options_.startup_s && running_since_ > start_t_)
    hold = HoldReason::kStartUp;
  else if (degraded || !(sigma > 0.0) || !std::isfinite(leak) ||
           (use_charge && (!std::isfinite(charge) || !std::isfinite(charge_sigma))))
    hold = HoldReason::kDegraded;
  report_.hold = hold;
  if (hold != HoldReason::kNone) {
    z_sum_ = z_time_ = c_sum_ = c_var_sum_ = f_sum_ = 0.0;  // a held interval is discarded
    return report_;
  }

  z_sum_ += dt * (leak - options_.rate_allowance) / std::max(sigma, options_.sigma_floor);
  z_time_ += dt;
  if (use_charge) {
    c_sum_ += dt * charge;
    c_var_sum_ += dt * charge_sigma * charge_sigma;
    f_sum_ += dt * compressor_hz;
  }
  if (z_time_ < options_.interval_s) return report_;

  // One decision on the interval's means.
  const double z = z_sum_ / z_time_;
  ++report_.decisions;
  report_.statistic = z;
  report_.rate_cusum = std::max(0.0, report_.rate_cusum + z - k_);
  if (use_charge) {
    const double c = c_sum_ / z_time_, c_var = c_var_sum_ / z_time_;
    report_.interval_charge = c;
    report_.interval_charge_sigma = std::sqrt(c_var);
    report_.interval_speed_hz = f_sum_ / z_time_;
    const std::size_t b = band(report_.interval_speed_hz);
    if (!report_.reference_learned) {
      band_sum_[b] += c * z_time_;
      band_time_[b] += z_time_;
      ref_time_ += z_time_;
      report_.reference_learned = ref_time_ >= options_.reference_s;
      report_.charge_reference = -1.0;
    } else if (band_time_[b] > 0.0) {
      report_.charge_reference = band_sum_[b] / band_time_[b];
      const double s = std::sqrt(charge_noise_ * charge_noise_ + c_var);
      const double zc = (report_.charge_reference - c) / s;
      report_.charge_statistic = zc;
      report_.charge_cusum = std::max(
          0.0, report_.charge_cusum + charge_scale_ * (zc - options_.charge_allowance / s));
    } else {
      report_.charge_reference = -1.0;  // a band the reference never saw: not judged
    }
  }
  z_sum_ = z_time_ = c_sum_ = c_var_sum_ = f_sum_ = 0.0;
  report_.cusum = std::max(report_.rate_cusum, report_.charge_cusum);
  const double S = report_.cusum;
  switch (report_.state) {
    case LeakState::kNormal:
      if (S > h_)
        report_.state = LeakState::kLeak;
      else if (S > 0.5 * h_)
        report_.state = LeakState::kSuspect;
      break;
    case LeakState::kSuspect:
      if (S > h_)
        report_.state = LeakState::kLeak;
      else if (S < 0.25 * h_)
        report_.state = LeakState::kNormal;
      break;
    case LeakState::kLeak:
      if (S < 0.25 * h_) report_.state = LeakState::kNormal;
      break;
  }
  if (report_.state != LeakState::kNormal && report_.first_suspect_s < 0.0)
    report_.first_suspect_s = t;
  if (report_.state == LeakState::kLeak && report_.first_leak_s < 0.0) report_.first_leak_s = t;
  return report_;
}

std::size_t LeakDetector::band(double compressor_hz) const {
  const double b = std::floor(compressor_hz / std::max(options_.reference_band_hz, 1.0));
  return static_cast<std::size_t>(std::clamp(b, 0.0, kBands - 1.0));
}

double LeakDetector::reference_charge(double compressor_hz) const {
  const std::size_t b = band(compressor_hz);
  if (!report_.reference_learned || !(band_time_[b] > 0.0)) return -1.0;
  return band_sum_[b] / band_time_[b];
}

void LeakDetector::save_state(std::span<double, kStateSize> out) const {
  std::size_t i = 0;
  const auto put = [&](double v) { out[i++] = v; };
  put(static_cast<double>(report_.state));
  put(static_cast<double>(report_.hold));
  put(report_.cusum);
  put(report_.statistic);
  put(static_cast<double>(report_.decisions));
  put(report_.first_suspect_s);
  put(report_.first_leak_s);
  put(start_t_);
  put(last_t_);
  put(running_ ? 1.0 : 0.0);
  put(running_since_);
  for (const double s : starts_)
    put(s);
  put(n_starts_);
  put(next_start_);
  put(z_sum_);
  put(z_time_);
  put(report_.rate_cusum);
  put(report_.charge_cusum);
  put(report_.charge_statistic);
  put(report_.charge_reference);
  put(c_sum_);
  put(c_var_sum_);
  put(f_sum_);
  put(ref_time_);
  put(report_.reference_learned ? 1.0 : 0.0);
  for (std::size_t b = 0; b < kBands; ++b) {
    put(band_sum_[b]);
    put(band_time_[b]);
  }
}

bool LeakDetector::restore_state(std::span<const double> in) {
  if (in.size() != kStateSize) return false;
  if (!std::all_of(in.begin(), in.end(), [](double v) { return std::isfinite(v); })) return false;
  const auto whole_in = [](double v, double lo, double hi) {
    return v >= lo && v <= hi && v == std::floor(v);
  };
  if (!whole_in(in[0], 0, 2) || !whole_in(in[1], 0, 5) || in[2] < 0.0 ||
      !whole_in(in[4], 0, 9e15) || !whole_in(in[9], 0, 1) || !whole_in(in[19], 0, 8) ||
      !whole_in(in[20], 0, 7) || in[22] < 0.0 || in[23] < 0.0 || in[24] < 0.0 ||
      in[2] != std::max(in[23], in[24]) || (in[26] < 0.0 && in[26] != -1.0) || in[28] < 0.0 ||
      in[29] < 0.0 || in[30] < 0.0 || !whole_in(in[31], 0, 1))
    return false;
  for (std::size_t b = 0; b < kBands; ++b)
    if (in[33 + 2 * b] < 0.0) return false;  // time in a band (after its sum at 32 + 2b)
  std::size_t i = 0;
  const auto get = [&] { return in[i++]; };
  report_.state = static_cast<LeakState>(static_cast<int>(get()));
  report_.hold = static_cast<HoldReason>(static_cast<int>(get()));
  report_.cusum = get();
  report_.statistic = get();
  report_.decisions = static_cast<std::uint64_t>(get());
  report_.first_suspect_s = get();
  report_.first_leak_s = get();
  start_t_ = get();
  last_t_ = get();
  running_ = get() != 0.0;
  running_since_ = get();
  for (double& s : starts_)
    s = get();
  n_starts_ = static_cast<int>(get());
  next_start_ = static_cast<int>(get());
  z_sum_ = get();
  z_time_ = get();
  report_.rate_cusum = get();
  report_.charge_cusum = get();
  report_.charge_statistic = get();
  report_.charge_reference = get();
  c_sum_ = get();
  c_var_sum_ = get();
  f_sum_ = get();
  ref_time_ = get();
  report_.reference_learned = get() != 0.0;
  for (std::size_t b = 0; b < kBands; ++b) {
    band_sum_[b] = get();
    band_time_[b] = get();
  }
  return true;
}

}  // namespace hvac_twin::est
