#include "daemon/runtime/scheduler.hpp"

#include <catch2/catch.hpp>
#include <chrono>
#include <thread>

#include "daemon/runtime/clock.hpp"

using namespace hvac_twin::runtime;
using namespace std::chrono_literals;

TEST_CASE("ticks fall on absolute deadlines: no drift however long the cycles take",
          "[scheduler]") {
  const std::int64_t period = 5'000'000;  // 5 ms
  const std::int64_t start = monotonic_ns() + period;
  FixedRateScheduler s(start, period);
  Tick t;
  for (std::uint64_t k = 0; k < 40; ++k) {
    REQUIRE(s.wait_next(t));
    CHECK(t.index == k);
    CHECK(t.due_ns == start + static_cast<std::int64_t>(k) * period);  // exact, not accumulated
    CHECK(t.woke_ns >= t.due_ns);
    // Work of varying length that stays inside the period.
    std::this_thread::sleep_for(std::chrono::microseconds(500 * (k % 4)));
  }
  CHECK(s.skipped_ticks() == 0);
}

TEST_CASE("a cycle that overruns skips the ticks it missed instead of bunching up", "[scheduler]") {
  const std::int64_t period = 10'000'000;  // 10 ms
  const std::int64_t start = monotonic_ns();
  FixedRateScheduler s(start, period);
  Tick t;
  REQUIRE(s.wait_next(t));
  CHECK(t.index == 0);
  std::this_thread::sleep_for(35ms);  // misses ticks 1, 2, 3
  REQUIRE(s.wait_next(t));
  CHECK(t.index >= 3);
  CHECK(t.ticks_since_last == t.index);
  CHECK(s.skipped_ticks() == t.index - 1);
  const std::uint64_t late = t.index;
  REQUIRE(s.wait_next(t));
  CHECK(t.index == late + 1);  // back on the grid
  CHECK(t.due_ns == start + static_cast<std::int64_t>(t.index) * period);
}

TEST_CASE("stop wakes a waiting scheduler at once", "[scheduler]") {
  FixedRateScheduler s(monotonic_ns() + 10'000'000'000, 10'000'000'000);  // first tick in 10 s
  std::thread stopper([&] {
    std::this_thread::sleep_for(50ms);
    s.stop();
  });
  const auto before = std::chrono::steady_clock::now();
  Tick t;
  CHECK_FALSE(s.wait_next(t));
  CHECK(std::chrono::steady_clock::now() - before < 5s);
  stopper.join();
  CHECK_FALSE(s.wait_next(t));
}
