#include "daemon/runtime/scheduler.hpp"

#include <chrono>
#include <stdexcept>

#include "daemon/runtime/clock.hpp"

namespace hvac_twin::runtime {

FixedRateScheduler::FixedRateScheduler(std::int64_t start_ns, std::int64_t period_ns)
    : start_ns_(start_ns), period_ns_(period_ns) {
  if (period_ns <= 0) throw std::invalid_argument("scheduler period must be positive");
}

bool FixedRateScheduler::wait_next(Tick& tick) {
  std::unique_lock lock(mutex_);
  if (stop_) return false;
  const std::int64_t now = monotonic_ns();
  // The next tick not yet taken, or the latest one that has already passed.
  std::uint64_t next = started_ ? last_index_ + 1 : 0;
  if (now > start_ns_) {
    const auto passed = static_cast<std::uint64_t>((now - start_ns_) / period_ns_);
    if (passed > next) next = passed;
  }
  const std::int64_t due = start_ns_ + static_cast<std::int64_t>(next) * period_ns_;
  // std::chrono::steady_clock is CLOCK_MONOTONIC on Linux; wait_until on it uses
  // pthread_cond_clockwait, an absolute wait on that clock.
  const std::chrono::steady_clock::time_point until{std::chrono::nanoseconds(due)};
  wake_.wait_until(lock, until, [this] { return stop_; });
  if (stop_) return false;
  tick.index = next;
  tick.due_ns = due;
  tick.woke_ns = monotonic_ns();
  tick.ticks_since_last = started_ ? next - last_index_ : 1;
  if (started_) skipped_ += next - last_index_ - 1;
  started_ = true;
  last_index_ = next;
  return true;
}

void FixedRateScheduler::stop() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
}

std::uint64_t FixedRateScheduler::skipped_ticks() const {
  std::lock_guard lock(mutex_);
  return skipped_;
}

}  // namespace hvac_twin::runtime
