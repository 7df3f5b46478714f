// Refrigerant leak detection on the estimated leak rate: a one-sided CUSUM with a designed
// false-alarm rate, alarm states with hysteresis, and holds while the model cannot judge.
//
// The filter's leak-rate estimate is strongly autocorrelated from cycle to cycle, so the
// detector decides once per `interval_s` of judgeable operation (long against the filter's
// memory), on the standardised estimate z = leak / sigma averaged over the interval:
//     S = max(0, S + z - k)
// k is half the shift (in sigma) the detector is designed to find quickly. The threshold h
// is chosen so that the in-control average run length (Siegmund's approximation for a normal
// CUSUM) equals the designed mean time between false alarms:
//     ARL0(h) = (exp(2k(h + 1.166)) - 2k(h + 1.166) - 1) / (2 k^2)   decisions.
// States: NORMAL -> SUSPECT when S > h/2, -> LEAK when S > h; LEAK stays until S falls below
// h/4 (hysteresis), SUSPECT returns to NORMAL below h/4.
// Held (no decision, S kept, reason published) while the compressor is off or has started less
// than `startup_s` ago, while it cycles (more than `max_starts_per_hour` starts), and while the
// estimates are degraded. A held interval is discarded, not averaged.
//
// Pure: time is passed in (model seconds). No allocation, no exceptions after construction.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

namespace hvac_twin::est {

enum class LeakState : std::uint8_t { kNormal, kSuspect, kLeak };
enum class HoldReason : std::uint8_t {
  kNone,
  kWarmUp,  // the filter has not converged yet
  kCompressorOff,
  kStartUp,   // the compressor started less than startup_s ago
  kCycling,   // too many compressor starts per hour
  kDegraded,  // estimates DEGRADED (stale inputs, no measurement fused, overrun)
};
std::string_view to_string(LeakState state);
std::string_view to_string(HoldReason reason);

struct LeakDetectorOptions {
  double interval_s = 1800.0;                 // one decision per this much judgeable time [s]
  double design_shift_sigma = 2.0;            // detect a leak of this many sigma quickly (k = /2)
  double false_alarm_interval_days = 3650.0;  // designed mean time between false alarms
  double warm_up_s = 3600.0;                  // no decision before the filter had this long [s]
  double startup_s = 900.0;                   // hold for this long after a compressor start [s]
  double min_compressor_speed_hz = 5.0;       // below this the compressor is off
  double max_starts_per_hour = 3.0;           // more: cycling
  double sigma_floor = 0.0;  // smallest sigma the estimate is standardised by [estimate unit]
};

struct LeakReport {
  LeakState state = LeakState::kNormal;
  HoldReason hold = HoldReason::kNone;
  double cusum = 0.0;      // S [sigma]
  double threshold = 0.0;  // h [sigma]
  double statistic = 0.0;  // the last decision's z [sigma]
  std::uint64_t decisions = 0;
  double first_suspect_s = -1.0;  // model time of the first SUSPECT / LEAK (-1: never)
  double first_leak_s = -1.0;
};

class LeakDetector {
 public:
  explicit LeakDetector(const LeakDetectorOptions& options = {});

  // One cycle at model time t [s]: the leak-rate estimate and its sigma [any unit, same for
  // both], the compressor speed [Hz] and whether the estimates are degraded.
  const LeakReport& step(double t, double leak, double sigma, double compressor_hz, bool degraded);

  [[nodiscard]] const LeakReport& report() const { return report_; }

  // Checkpoints: the detector's whole running state as numbers (alarm state, CUSUM, decision
  // accumulators, compressor-start history, times). The threshold is not saved: it follows from
  // the options. restore_state() returns false and changes nothing if `in` has another size or
  // a value no detector could have produced.
  static constexpr std::size_t kStateSize = 23;
  void save_state(std::span<double, kStateSize> out) const;
  bool restore_state(std::span<const double> in);
  [[nodiscard]] double threshold() const { return h_; }
  // Siegmund's in-control average run length for reference value k and threshold h.
  static double arl0(double k, double h);

 private:
  LeakDetectorOptions options_;
  double k_, h_;
  LeakReport report_;
  double start_t_ = -1.0;  // first step
  double last_t_ = -1.0;
  bool running_ = false;
  double running_since_ = -1.0;  // compressor on since
  double starts_[8] = {};        // ring of recent start times
  int n_starts_ = 0, next_start_ = 0;
  double z_sum_ = 0.0, z_time_ = 0.0;  // accumulation over the current interval
};

}  // namespace hvac_twin::est
