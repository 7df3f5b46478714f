// Fixed-rate scheduling on absolute CLOCK_MONOTONIC deadlines: tick k is due at
// start + k * period exactly, so rounding and cycle-time jitter never accumulate (no drift over
// hours). A cycle that runs past later ticks skips them (counted) instead of bunching cycles up.
//
// Threads: wait_next() from the cycle thread; stop() from any thread wakes it at once.
// No allocation after construction.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <mutex>

namespace hvac_twin::runtime {

struct Tick {
  std::uint64_t index = 0;             // k: this tick is due at start + k * period
  std::int64_t due_ns = 0;             // CLOCK_MONOTONIC [ns]
  std::int64_t woke_ns = 0;            // when wait_next() returned [ns]
  std::uint64_t ticks_since_last = 1;  // k - previous k (> 1 when ticks were skipped)
  // The cycle's CLOCK_REALTIME stamp [ns]; 0 (the scheduler's): the cycle reads the clock.
  // A replay sets the recorded one.
  std::int64_t wall_ns = 0;
};

class FixedRateScheduler {
 public:
  // The first tick is due at start_ns; period_ns > 0.
  FixedRateScheduler(std::int64_t start_ns, std::int64_t period_ns);

  // Sleeps until the next due tick that has not passed and returns it; false once stop() was
  // called. If the caller is late past one or more ticks, the latest passed tick is returned at
  // once and the ones before it are skipped.
  bool wait_next(Tick& tick);
  void stop();

  [[nodiscard]] std::uint64_t skipped_ticks() const;
  [[nodiscard]] std::int64_t period_ns() const { return period_ns_; }

 private:
  const std::int64_t start_ns_;
  const std::int64_t period_ns_;
  bool started_ = false;
  std::uint64_t last_index_ = 0;
  std::uint64_t skipped_ = 0;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
};

}  // namespace hvac_twin::runtime
