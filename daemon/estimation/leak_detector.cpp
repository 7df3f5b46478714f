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

LeakDetector::LeakDetector(const LeakDetectorOptions& options)
    : options_(options), k_(0.5 * options.design_shift_sigma) {
  // The threshold whose in-control run length is the designed time between false alarms,
  // counted in decisions (ARL0 grows monotonically with h: bisection).
  const double decisions =
      options.false_alarm_interval_days * 86400.0 / std::max(options.interval_s, 1.0);
  double lo = 0.0, hi = 100.0;
  for (int i = 0; i < 200; ++i) {
    const double mid = 0.5 * (lo + hi);
    (arl0(k_, mid) < decisions ? lo : hi) = mid;
  }
  h_ = hi;
  report_.threshold = h_;
}

const LeakReport& LeakDetector::step(double t, double leak, double sigma, double compressor_hz,
                                     bool degraded) {
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
  else if (degraded || !(sigma > 0.0) || !std::isfinite(leak))
    hold = HoldReason::kDegraded;
  report_.hold = hold;
  if (hold != HoldReason::kNone) {
    z_sum_ = z_time_ = 0.0;  // a held interval is discarded
    return report_;
  }

  z_sum_ += dt * leak / sigma;
  z_time_ += dt;
  if (z_time_ < options_.interval_s) return report_;

  // One decision on the interval's mean standardised leak rate.
  const double z = z_sum_ / z_time_;
  z_sum_ = z_time_ = 0.0;
  ++report_.decisions;
  report_.statistic = z;
  report_.cusum = std::max(0.0, report_.cusum + z - k_);
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
}

bool LeakDetector::restore_state(std::span<const double> in) {
  if (in.size() != kStateSize) return false;
  if (!std::all_of(in.begin(), in.end(), [](double v) { return std::isfinite(v); })) return false;
  const auto whole_in = [](double v, double lo, double hi) {
    return v >= lo && v <= hi && v == std::floor(v);
  };
  if (!whole_in(in[0], 0, 2) || !whole_in(in[1], 0, 5) || in[2] < 0.0 ||
      !whole_in(in[4], 0, 9e15) || !whole_in(in[9], 0, 1) || !whole_in(in[19], 0, 8) ||
      !whole_in(in[20], 0, 7) || in[22] < 0.0)
    return false;
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
  return true;
}

}  // namespace hvac_twin::est
