// Rate limit for a warning that would repeat every cycle while a condition lasts (a cycle over
// its deadline: a 1 us period logged about 12 000 such lines a second). An episode starts with
// the first occurrence, which is logged with what it was; later occurrences are counted, and at
// most one summary line per `interval_ns` says how many there were and the worst value; the
// episode ends, with a line saying so, once a whole interval passed without an occurrence.
//
// Pure: the caller passes the clock and logs; no allocation.
#pragma once

#include <algorithm>
#include <cstdint>

namespace hvac_twin::runtime {

struct RepeatStep {
  bool start = false;       // the episode's first occurrence: log it
  bool summary = false;     // an interval of occurrences: log `count` and `worst`
  bool end = false;         // an interval without one: log the episode's end with `count`, `worst`
  std::uint64_t count = 0;  // occurrences since the last line logged
  double worst = 0.0;       // the largest value among them
  std::uint64_t total = 0;  // occurrences in the episode so far
};

class RepeatLog {
 public:
  explicit RepeatLog(std::int64_t interval_ns) : interval_ns_(interval_ns) {}

  // After every cycle: whether the condition occurred, its value (e.g. the cycle's time), now.
  RepeatStep observe(bool occurred, double value, std::int64_t now_ns) {
    RepeatStep s;
    if (occurred) {
      last_occurrence_ns_ = now_ns;
      ++total_;
      if (!active_) {
        active_ = true;
        last_line_ns_ = now_ns;
        total_ = 1;
        s.start = true;
        s.worst = value;
        s.count = 1;
      } else {
        ++count_;
        worst_ = count_ == 1 ? value : std::max(worst_, value);
        if (now_ns - last_line_ns_ >= interval_ns_) {
          s.summary = true;
          take(s, now_ns);
        }
      }
    } else if (active_ && now_ns - last_occurrence_ns_ >= interval_ns_) {
      s.end = true;
      take(s, now_ns);
      active_ = false;
    }
    s.total = total_;
    return s;
  }

  [[nodiscard]] bool active() const { return active_; }

 private:
  void take(RepeatStep& s, std::int64_t now_ns) {
    s.count = count_;
    s.worst = worst_;
    count_ = 0;
    worst_ = 0.0;
    last_line_ns_ = now_ns;
  }

  std::int64_t interval_ns_;
  bool active_ = false;
  std::int64_t last_line_ns_ = 0;
  std::int64_t last_occurrence_ns_ = 0;
  std::uint64_t count_ = 0;  // since the last line
  double worst_ = 0.0;
  std::uint64_t total_ = 0;
};

}  // namespace hvac_twin::runtime
