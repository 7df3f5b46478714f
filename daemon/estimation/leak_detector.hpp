// Refrigerant leak detection on the filter's estimates: one-sided CUSUMs with a designed
// false-alarm rate, alarm states with hysteresis, and holds while the model cannot judge.
//
// The estimates are strongly autocorrelated from cycle to cycle, so the detector decides once
// per `interval_s` of judgeable operation (long against the filter's memory), on interval means.
//
// Leak rate (always): z = (leak - rate_allowance) / max(sigma, sigma_floor) averaged over the
// interval,
//     S_rate = max(0, S_rate + z - k).
// The allowance is the leak-rate estimate's in-control level: a filter whose model is coarser
// than the plant uses the rate as slack for the mismatch, so the rate judged in a tight unit is
// not zero-mean (leak_bench, 7 days of normal operation, allowance 0: at stop 45 z mean 0.98,
// sd 0.15, lag-1 autocorrelation 0.91, S_rate 82 % of the way to SUSPECT in a week; at stop 51
// the estimate 2.39 g/h on average, at most 2.96 g/h, z at most 0.95 against k = 1). Only a
// rate beyond the allowance accumulates; as for the charge, the false-alarm rate is then that
// of the in-control wander exceeding it.
// The sigma is the caller's: the daemon passes the published one, which carries the model's
// structural wander of the rate (plant_models: SignalInfo::model_error), so that an offset that
// drifts with the operating point does not read as a leak.
// The floor matters for a constrained filter: while its leak-rate estimate rests on a lower
// bound the PDF truncation collapses the sigma it reports (measured on the heat pump: 0.02 g/h
// on the bound against 0.19 g/h off it), and a small excursion would read as many sigma.
//
// Charge deficit (when the charge is passed in and charge_allowance > 0): a filter whose model
// is coarser than the plant estimates the charge with an offset that moves with the operating
// point (heat pump, 10-cell model against a 20-cell plant: +8 % of the nameplate charge at
// 20-30 Hz, +4 % at 85-90 Hz, within about +-1 % at one speed). The offset is bounded; a
// leak's deficit grows without bound. So the first `reference_s` of judgeable operation after
// warm-up average the charge estimate into references C_ref(b) (the unit as commissioned), one
// per band b of compressor speed (`reference_band_hz` wide, by the interval's mean speed), and
// afterwards each interval whose band has a reference gives the deficit D = C_ref(b) - charge
// (interval means) and, with its scale s = sqrt(charge_noise^2 + sigma_charge^2),
//     z_c = D / s,   S_charge = max(0, S_charge + (h / h_c) (z_c - a / s)):
// the allowance a is the CUSUM's reference value in the charge's unit (the model's in-control
// wander within a band, so only a deficit beyond it accumulates), counted in units of the
// deficit's in-control noise. h_c is the threshold designed (as below) for k_c = a /
// charge_noise, and h / h_c puts S_charge on the rate statistic's scale so that one threshold
// serves both. With charge_noise = a this is z_c - 1 (k = 1), the design before the noise was
// measured: in leak_bench's 7 days of normal operation an interval's deficit had a standard
// deviation of about 1/3 of the allowance (3.4 g against 10 g; largest 7.5 g), so that design
// counted a deficit beyond the allowance about three times too slowly. An interval in a band the
// reference period never ran in is judged on the leak rate alone. This finds slow leaks, whose rate
// drowns in the leak-rate estimate's noise, in a bounded time (deficit ~ rate x time). A leak
// already present while the references are learned lowers them and delays detection.
//
// k is half the shift (in sigma) the detector is designed to find quickly. The threshold h is
// chosen so that the in-control average run length (Siegmund's approximation for a normal
// CUSUM) equals the designed mean time between false alarms:
//     ARL0(h) = (exp(2k(h + 1.166)) - 2k(h + 1.166) - 1) / (2 k^2)   decisions;
// with both statistics each is designed for twice that time, so that either raising an alarm
// keeps the designed rate. (The design assumes independent, unit-variance decisions. Neither
// holds exactly: leak_bench prints both statistics' in-control mean, sd and lag-1
// autocorrelation. For the charge deficit, whose in-control wander the allowance bounds, the
// false-alarm rate is that of the wander exceeding the allowance: the figure is nominal.)
// States follow S = max(S_rate, S_charge): NORMAL -> SUSPECT when S > h/2, -> LEAK when S > h;
// LEAK stays until S falls below h/4 (hysteresis), SUSPECT returns to NORMAL below h/4.
// Held (no decision, S kept, reason published) while the compressor is off or has started less
// than `startup_s` ago, while it cycles (more than `max_starts_per_hour` starts), and while the
// estimates are degraded. A held interval is discarded, not averaged.
//
// Pure: time is passed in (model seconds). No allocation, no exceptions after construction.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
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
  kDegraded,  // estimates degraded: stale inputs, no measurement fused, a reset, lost track
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
  double sigma_floor = 0.0;     // smallest leak-rate sigma the estimate is divided by [its unit]
  double rate_allowance = 0.0;  // the leak-rate estimate's in-control level [its unit]
  // The charge-deficit statistic: off at 0. The model's in-control wander of the charge
  // estimate [charge unit], and the judgeable time the reference charge is averaged over [s].
  double charge_allowance = 0.0;
  double reference_s = 86400.0;
  double reference_band_hz = 20.0;  // width of the compressor-speed bands of the reference
  // The in-control standard deviation of an interval's charge deficit beyond the filter's own
  // sigma [charge unit]: the scale of the charge statistic. 0: the allowance (k = 1).
  double charge_noise = 0.0;
};

struct LeakReport {
  LeakState state = LeakState::kNormal;
  HoldReason hold = HoldReason::kNone;
  double cusum = 0.0;      // S = max(S_rate, S_charge) [sigma]: what the state follows
  double threshold = 0.0;  // h [sigma]
  double statistic = 0.0;  // the last decision's leak-rate z, beyond the allowance [sigma]
  std::uint64_t decisions = 0;
  double first_suspect_s = -1.0;  // model time of the first SUSPECT / LEAK (-1: never)
  double first_leak_s = -1.0;
  double rate_cusum = 0.0;         // S_rate [sigma]
  double charge_cusum = 0.0;       // S_charge [sigma]
  double charge_statistic = 0.0;   // the last decision's z_c [sigma]
  double charge_reference = -1.0;  // C_ref of the last decision's band [charge unit]; -1: none
  bool reference_learned = false;  // the reference period is over
  // The last decision's interval means: the charge estimate and its sigma [charge unit] (NaN
  // when the charge is not judged) and the compressor speed [Hz]. For checking the design.
  double interval_charge = std::numeric_limits<double>::quiet_NaN();
  double interval_charge_sigma = std::numeric_limits<double>::quiet_NaN();
  double interval_speed_hz = 0.0;
};

class LeakDetector {
 public:
  explicit LeakDetector(const LeakDetectorOptions& options = {});

  // One cycle at model time t [s]: the leak-rate estimate and its sigma [any unit, same for
  // both], the compressor speed [Hz] and whether the estimates are degraded.
  const LeakReport& step(double t, double leak, double sigma, double compressor_hz, bool degraded);
  // The same with the charge estimate and its sigma [any unit, the allowance's], for the
  // charge-deficit statistic.
  const LeakReport& step(double t, double leak, double sigma, double charge, double charge_sigma,
                         double compressor_hz, bool degraded);

  [[nodiscard]] const LeakReport& report() const { return report_; }
  [[nodiscard]] const LeakDetectorOptions& options() const { return options_; }
  // The learnt reference charge of the speed band `compressor_hz` falls in, once the reference
  // period is over; -1 before, or for a band the reference period never ran in.
  [[nodiscard]] double reference_charge(double compressor_hz) const;

  // Checkpoints: the detector's whole running state as numbers (alarm state, CUSUMs, decision
  // accumulators, compressor-start history, times, the charge references per speed band). The
  // threshold is not saved: it follows from the options. restore_state() returns false and changes
  // nothing if `in` has another size or a value no detector could have produced.
  static constexpr std::size_t kBands = 5;  // speed bands; the last takes every higher speed
  static constexpr std::size_t kStateSize = 32 + 2 * kBands;
  void save_state(std::span<double, kStateSize> out) const;
  bool restore_state(std::span<const double> in);
  [[nodiscard]] double threshold() const { return h_; }
  // Siegmund's in-control average run length for reference value k and threshold h.
  static double arl0(double k, double h);

 private:
  const LeakReport& step_with(double t, double leak, double sigma, double charge,
                              double charge_sigma, double compressor_hz, bool degraded,
                              bool use_charge);

  [[nodiscard]] std::size_t band(double compressor_hz) const;

  LeakDetectorOptions options_;
  double k_, h_;
  double charge_noise_ = 0.0;  // the charge statistic's scale [charge unit]
  double charge_scale_ = 1.0;  // h / h_c: S_charge on the rate statistic's scale
  LeakReport report_;
  double start_t_ = -1.0;  // first step
  double last_t_ = -1.0;
  bool running_ = false;
  double running_since_ = -1.0;  // compressor on since
  double starts_[8] = {};        // ring of recent start times
  int n_starts_ = 0, next_start_ = 0;
  double z_sum_ = 0.0, z_time_ = 0.0;     // accumulation over the current interval
  double c_sum_ = 0.0, c_var_sum_ = 0.0;  // charge and its variance, over the same interval
  double f_sum_ = 0.0;                    // and the compressor speed
  double ref_time_ = 0.0;                 // judgeable time in the reference so far
  double band_sum_[kBands] = {}, band_time_[kBands] = {};  // the references per speed band
};

}  // namespace hvac_twin::est
