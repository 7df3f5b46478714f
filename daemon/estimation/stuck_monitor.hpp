// Whether a measured point is stuck: a dead transmitter, or a gateway holding its last value,
// reads the same raw value cycle after cycle while the plant moves. A raw value that has not
// changed at all for `stuck_after_s` model seconds is stuck if, over the same time, the model
// moved it by at least `move_threshold` (4 sigma of the point's noise in the daemon): the sum of
// the model's own change of the point over each period (its prediction minus the estimate it
// predicted from). The sum, not the spread of the predictions: a frozen reading that is fused
// pulls every estimate back to it, so the predictions stay close to it while the model keeps
// pushing the same way, period after period. A plant at rest, or a quantised signal that holds
// while the model agrees, is not flagged. Once stuck, the point stays stuck until its raw value
// changes (or it is not read GOOD).
//
// The caller leaves a stuck point out of the update (a frozen reading fused as GOOD holds the
// estimate at a past state with the measurement's full weight) and says so. Pure: no I/O, no
// clock, no allocation.
#pragma once

#include <cmath>

namespace hvac_twin::est {

// The daemon's move threshold in sigmas of the point's measurement noise.
inline constexpr double kStuckMoveSigmas = 4.0;

struct StuckStep {
  bool stuck = false;        // leave the point out of this cycle's update
  bool started = false;      // the episode's first stuck cycle: log it
  bool ended = false;        // the first cycle after an episode: the value changed or not GOOD
  double unchanged_s = 0.0;  // how long the raw value has not changed
  double moved = 0.0;        // |the model's summed change of the point| meanwhile
};

class StuckMonitor {
 public:
  StuckMonitor() = default;
  // stuck_after_s 0: never stuck.
  StuckMonitor(double stuck_after_s, double move_threshold)
      : stuck_after_s_(stuck_after_s), move_threshold_(move_threshold) {}

  // Every cycle: whether the point was read GOOD, its raw value as read (compared exactly), the
  // model's change of the point over the last period (NaN: unknown, counts as none), and the
  // model time.
  StuckStep observe(bool good, double raw, double drift, double t_s) {
    StuckStep s;
    if (!good || !have_ || raw != last_raw_) {
      s.ended = stuck_;
      stuck_ = false;
      have_ = good;
      last_raw_ = raw;
      since_s_ = t_s;
      sum_ = 0.0;
      return s;
    }
    if (std::isfinite(drift)) sum_ += drift;
    s.unchanged_s = t_s - since_s_;
    s.moved = std::abs(sum_);
    if (!stuck_ && stuck_after_s_ > 0.0 && s.unchanged_s >= stuck_after_s_ &&
        s.moved >= move_threshold_) {
      stuck_ = true;
      s.started = true;
    }
    s.stuck = stuck_;
    return s;
  }

  [[nodiscard]] bool stuck() const { return stuck_; }

 private:
  double stuck_after_s_ = 0.0;
  double move_threshold_ = 0.0;
  bool have_ = false;
  bool stuck_ = false;
  double last_raw_ = 0.0;
  double since_s_ = 0.0;
  double sum_ = 0.0;
};

}  // namespace hvac_twin::est
