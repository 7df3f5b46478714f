#include "daemon/runtime/scheduler.hpp"

#include <catch2/catch.hpp>
#include <chrono>
#include <thread>

#include "daemon/runtime/clock.hpp"

using namespace hvac_twin::runtime;
using namespace std::chrono_literals;

TEST_CASE("ticks fall on absolute deadlines: no drift however long the cycles take",
          "[scheduler]") {
  const std::int64_t period = 20'000'000;  // 20 ms
  const std::int64_t start = monotonic_ns() + period;
  FixedRateScheduler s(start, period);
  Tick t;
  std::uint64_t last = 0;
  for (std::uint64_t k = 0; k < 40; ++k) {
    REQUIRE(s.wait_next(t));
    // Exactly on the grid from the start, not accumulated from the previous wake-up.
    CHECK(t.due_ns == start + static_cast<std::int64_t>(t.index) * period);
    CHECK(t.woke_ns >= t.due_ns);
    if (k == 0) CHECK(t.index == 0);
    if (k > 0) CHECK(t.ticks_since_last == t.index - last);
    last = t.index;
    // Work of varying length that stays well inside the period.
    std::this_thread::sleep_for(std::chrono::microseconds(500 * (k % 4)));
  }
  // Every cycle fitted its period, so every tick ran; a machine too loaded to wake the thread
  // within the 18 ms left would skip one (counted, and still on the grid), which is tolerated.
  CHECK(s.skipped_ticks() == last - 39);
  CHECK(s.skipped_ticks() <= 2);
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
