// RejectionStreaks: per measurement slot, the run of consecutive gate rejections and the
// re-admission schedule both filters keep (ekf.hpp, "Re-admission"; enkf.hpp, the lone point).
//
// A slot's streak counts its rejections in a row; a point is faulty once that reaches the
// filter's max_consecutive_rejections. It also remembers the streak's first reading and whether
// a later one differed (a reading that never moved is a frozen transmitter, the stuck check's to
// judge, and is never re-admitted on the filter's own initiative).
//
// Re-admission: an armed slot is tested against the initial covariance when its streak reaches
// `at`; each test moves the next one `interval` rejections further and doubles the interval (a
// transmitter that stays wrong costs a reset ever more rarely, up to kMaxInterval). at = 0 means
// disarmed. Let in by the gate: disarmed and the back-off forgotten. Let in by a reset: kept
// armed, tested again `interval` rejections after it falls out (one update linearised far from
// the truth may not be enough).
//
// resize() allocates (construction only); everything else is allocation-free and noexcept.
// Indices are not checked: the filters bound them by the slots they were sized for.
#pragma once

#include <algorithm>
#include <cstddef>
#include <vector>

namespace hvac_twin::est {

class RejectionStreaks {
 public:
  void resize(std::size_t slots) {
    count_.assign(slots, 0);
    at_.assign(slots, 0);
    interval_.assign(slots, 0);
    first_.assign(slots, 0.0);
    varied_.assign(slots, 0);
  }
  [[nodiscard]] std::size_t size() const noexcept { return count_.size(); }

  // Forgets every streak and schedule (a reset from outside, a restore).
  void clear() noexcept {
    std::fill(count_.begin(), count_.end(), 0);
    std::fill(at_.begin(), at_.end(), 0);
    std::fill(interval_.begin(), interval_.end(), 0);  // a fresh back-off
  }

  // Slot i's reading `value` failed the gate.
  void reject(std::size_t i, double value) noexcept {
    if (++count_[i] == 1) {
      first_[i] = value;
      varied_[i] = 0;
    } else if (value != first_[i]) {
      varied_[i] = 1;
    }
  }
  // Slot i's reading passed the gate (its streak ends; the schedule is the caller's: disarm()).
  void accept(std::size_t i) noexcept { count_[i] = 0; }
  // Slot i's streak set to `count` rejections (a re-test after a reset decides anew).
  void set_count(std::size_t i, int count) noexcept { count_[i] = count; }
  void uncount(std::size_t i) noexcept { --count_[i]; }  // a rejection taken back (re-gated)

  [[nodiscard]] int count(std::size_t i) const noexcept { return count_[i]; }
  [[nodiscard]] bool faulty(std::size_t i, int max_consecutive) const noexcept {
    return count_[i] >= max_consecutive;
  }
  [[nodiscard]] bool varied(std::size_t i) const noexcept { return varied_[i] != 0; }
  [[nodiscard]] bool armed(std::size_t i) const noexcept { return at_[i] != 0; }

  // Let in by the gate: disarmed, the back-off forgotten.
  void disarm(std::size_t i) noexcept { at_[i] = interval_[i] = 0; }
  // Fused after a reset's re-test: disarmed, the back-off kept.
  void disarm_keeping_backoff(std::size_t i) noexcept { at_[i] = 0; }
  // Let in by a reset: stays armed, tested again `interval` rejections after it falls out.
  void keep_armed(std::size_t i) noexcept { at_[i] = interval_[i]; }

  // A faulty point whose reading moved during its streak (the only available one, or one just
  // after a reset for lost track): armed (if it is not yet), its test due now; take_due() then sets
  // the next one 2 x max_consecutive later. With a back-off kept from an earlier test
  // (disarm_keeping_backoff(): fused between two streaks while the filter recovers), the test is
  // due when the streak reaches that interval: a sensor that is let in and falls out again costs
  // a reset ever more rarely, as one that stays out does.
  void arm_now(std::size_t i, int max_consecutive) noexcept {
    if (at_[i] != 0 || varied_[i] == 0) return;
    at_[i] = std::max(count_[i], interval_[i]);
    interval_[i] = std::max(interval_[i], max_consecutive);
  }
  // A point held out at a reset whose re-test failed: armed (if it is not yet), tested `interval`
  // (at least `min_interval`) rejections from now.
  void arm_later(std::size_t i, int min_interval) noexcept {
    if (at_[i] != 0) return;
    interval_[i] = std::max(interval_[i], min_interval);
    at_[i] = count_[i] + interval_[i];
  }
  // Whether armed slot i's test is due; if so, the next one is scheduled (the interval doubled).
  bool take_due(std::size_t i) noexcept {
    if (at_[i] == 0 || count_[i] < at_[i]) return false;
    interval_[i] = std::min(2 * interval_[i], kMaxInterval);
    at_[i] = count_[i] + interval_[i];
    return true;
  }

  static constexpr int kMaxInterval = 1 << 20;

 private:
  std::vector<int> count_;     // rejections in a row
  std::vector<int> at_;        // streak length of the next re-admission test (0: disarmed)
  std::vector<int> interval_;  // rejections from one test to the next
  std::vector<double> first_;  // the streak's first reading
  std::vector<char> varied_;   // a later reading in the streak differed from it
};

}  // namespace hvac_twin::est
