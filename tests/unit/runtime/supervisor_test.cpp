#include "daemon/runtime/supervisor.hpp"

#include <unistd.h>

#include <atomic>
#include <catch2/catch.hpp>
#include <chrono>
#include <cstdlib>
#include <thread>
#include <vector>

#include "daemon/runtime/clock.hpp"
#include "daemon/runtime/notify.hpp"
#include "tests/support/notify_socket.hpp"

using namespace hvac_twin::runtime;
using namespace std::chrono_literals;

namespace {

struct NotifyEnv {
  hvac_twin::test::NotifySocket socket;
  NotifyEnv() {
    setenv("NOTIFY_SOCKET", socket.path().c_str(), 1);
    setenv("WATCHDOG_USEC", "2000000", 1);
    unsetenv("WATCHDOG_PID");
  }
  ~NotifyEnv() {
    unsetenv("NOTIFY_SOCKET");
    unsetenv("WATCHDOG_USEC");
  }
};

SupervisorOptions quiet_options() {
  SupervisorOptions o;
  o.hang_exit = false;
  o.overrun_limit = 2;
  return o;
}

// A supervisor with quiet_options() whose ping changes are recorded in `changes`.
struct PingRecorder {
  NotifyEnv env;
  const SystemdNotifier notifier;
  std::vector<PingChange> changes;
  CycleSupervisor sup;
  explicit PingRecorder(std::size_t units)
      : sup(units, notifier, quiet_options(), {},
            [this](const PingChange& c) { changes.push_back(c); }) {}
};

}  // namespace

TEST_CASE("the notifier speaks the sd_notify protocol", "[notify]") {
  NotifyEnv env;
  const SystemdNotifier n;
  CHECK(n.enabled());
  CHECK(n.watchdog_interval_ns() == 2'000'000'000);
  n.ready();
  n.status("running 1 unit(s)");
  n.watchdog();
  n.stopping();
  const auto got = env.socket.receive(2s, "STOPPING=1");
  REQUIRE(got.size() == 4);
  CHECK(got[0] == "READY=1");
  CHECK(got[1] == "STATUS=running 1 unit(s)");
  CHECK(got[2] == "WATCHDOG=1");
  CHECK(got[3] == "STOPPING=1");
}

TEST_CASE("WATCHDOG=1 only once every unit has completed a cycle", "[supervisor]") {
  NotifyEnv env;
  const SystemdNotifier n;
  CycleSupervisor sup(2, n, quiet_options(), {});
  const std::int64_t t0 = monotonic_ns();
  sup.cycle_started(0, t0);
  CHECK_FALSE(sup.cycle_finished(0, t0 + 1, false));  // unit 1 has not completed yet
  CHECK_FALSE(sup.cycle_finished(0, t0 + 2, false));
  sup.cycle_started(1, t0 + 3);
  CHECK(sup.cycle_finished(1, t0 + 4, false));        // now both have
  CHECK_FALSE(sup.cycle_finished(1, t0 + 5, false));  // unit 0 again owes a cycle
  CHECK(sup.pings() == 1);
  const auto got = env.socket.receive(1s, "WATCHDOG=1");
  REQUIRE(got.size() == 1);
  CHECK(got[0] == "WATCHDOG=1");
}

TEST_CASE("consecutive overruns withhold the pings until a cycle is on time", "[supervisor]") {
  NotifyEnv env;
  const SystemdNotifier n;
  CycleSupervisor sup(1, n, quiet_options(), {});
  std::int64_t t = monotonic_ns();
  CHECK(sup.cycle_finished(0, ++t, true));        // one overrun: still pinging
  CHECK_FALSE(sup.cycle_finished(0, ++t, true));  // second in a row: limit 2 reached
  CHECK(sup.pings_withheld());
  CHECK_FALSE(sup.cycle_finished(0, ++t, true));
  CHECK(sup.cycle_finished(0, ++t, false));  // on time again
  CHECK_FALSE(sup.pings_withheld());
}

TEST_CASE("the pings stopping and resuming are reported once each, with the cause",
          "[supervisor]") {
  // Issue 17: when overruns withheld the pings, nothing was logged. The daemon logs these reports.
  PingRecorder r(1);
  auto& sup = r.sup;
  const auto& changes = r.changes;
  const std::int64_t t0 = monotonic_ns();
  CHECK(sup.cycle_finished(0, t0, true));
  CHECK(changes.empty());  // one overrun: still pinging
  CHECK_FALSE(sup.cycle_finished(0, t0 + 100, true));
  REQUIRE(changes.size() == 1);  // the limit (2) reached: stopped
  CHECK(changes[0].stopped);
  CHECK(changes[0].unit == 0);
  CHECK(changes[0].consecutive_overruns == 2);
  for (int i = 2; i < 10; ++i)
    CHECK_FALSE(sup.cycle_finished(0, t0 + 100 * i, true));
  CHECK(changes.size() == 1);  // still stopped: not reported again
  CHECK(sup.cycle_finished(0, t0 + 1000, false));
  REQUIRE(changes.size() == 2);  // on time again: resumed
  CHECK_FALSE(changes[1].stopped);
  CHECK(changes[1].consecutive_overruns == 10);
  CHECK(changes[1].withheld_ns == 900);
  CHECK(sup.cycle_finished(0, t0 + 1100, false));
  CHECK(sup.cycle_finished(0, t0 + 1200, true));
  CHECK(changes.size() == 2);
}

TEST_CASE("with several units the pings resume only when no unit is over the limit",
          "[supervisor]") {
  PingRecorder r(2);
  auto& sup = r.sup;
  const auto& changes = r.changes;
  std::int64_t t = monotonic_ns();
  for (int i = 0; i < 2; ++i) {
    sup.cycle_finished(0, ++t, true);
    sup.cycle_finished(1, ++t, true);
  }
  REQUIRE(changes.size() == 1);  // unit 0 reached the limit first; unit 1 adds no report
  CHECK(changes[0].stopped);
  CHECK(changes[0].unit == 0);
  CHECK_FALSE(sup.cycle_finished(0, ++t, false));  // unit 1 still over the limit
  CHECK(changes.size() == 1);
  CHECK(sup.pings_withheld());
  CHECK(sup.cycle_finished(1, ++t, false));
  REQUIRE(changes.size() == 2);
  CHECK_FALSE(changes[1].stopped);
  CHECK(changes[1].unit == 1);
  CHECK_FALSE(sup.pings_withheld());
}

TEST_CASE("pings are rate-limited to the minimum interval", "[supervisor]") {
  NotifyEnv env;
  const SystemdNotifier n;
  auto o = quiet_options();
  o.min_ping_interval_ns = 1'000'000'000;
  CycleSupervisor sup(1, n, o, {});
  const std::int64_t t0 = monotonic_ns();
  CHECK(sup.cycle_finished(0, t0, false));
  CHECK_FALSE(sup.cycle_finished(0, t0 + 500'000'000, false));
  CHECK(sup.cycle_finished(0, t0 + 1'100'000'000, false));
}

TEST_CASE("a cycle running past the hang timeout is reported once", "[supervisor]") {
  NotifyEnv env;
  const SystemdNotifier n;
  auto o = quiet_options();
  o.hang_timeout_ns = 100'000'000;
  o.check_interval_ns = 10'000'000;
  std::atomic<int> reports{0};
  std::atomic<std::int64_t> reported_for{0};
  CycleSupervisor sup(2, n, o, [&](std::size_t unit, std::int64_t running) {
    CHECK(unit == 1);
    reported_for = running;
    ++reports;
  });
  sup.start();
  sup.cycle_started(1, monotonic_ns());
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (reports == 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(5ms);
  std::this_thread::sleep_for(100ms);  // it must not be reported again
  sup.stop();
  CHECK(reports == 1);
  CHECK(reported_for > 100'000'000);
  CHECK(sup.hangs() == 1);
}

TEST_CASE("a cycle starved of the CPU is not hung: its run-queue delay does not count",
          "[supervisor]") {
  NotifyEnv env;
  const SystemdNotifier n;
  auto o = quiet_options();
  o.hang_timeout_ns = 100'000'000;
  o.check_interval_ns = 10'000'000;
  // The cycle thread waits for a CPU the whole time, then (starved = false) only runs.
  const std::int64_t t0 = monotonic_ns();
  std::atomic<bool> starved{true};
  std::atomic<std::int64_t> frozen_wait{0};
  o.runqueue_wait_ns = [&](pid_t) -> std::int64_t {
    if (starved) frozen_wait = monotonic_ns() - t0;
    return frozen_wait;
  };
  std::atomic<int> reports{0};
  CycleSupervisor sup(1, n, o, [&](std::size_t, std::int64_t) { ++reports; });
  sup.attach_thread(0, 4242);
  sup.start();
  sup.cycle_started(0, t0);
  std::this_thread::sleep_for(400ms);  // four hang timeouts of wall time, all spent waiting
  CHECK(reports == 0);
  CHECK(sup.hangs() == 0);
  starved = false;  // from now on the time counts
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (reports == 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(5ms);
  sup.stop();
  CHECK(reports == 1);
}

TEST_CASE("the run-queue delay of a thread is read from the kernel", "[supervisor]") {
  const std::int64_t first = thread_runqueue_wait_ns(::gettid());
  REQUIRE(first >= 0);  // Debian's kernels keep schedstat (CONFIG_SCHED_INFO)
  volatile double sink = 0.0;
  for (int i = 0; i < 1'000'000; ++i)
    sink = sink + 1.0;
  CHECK(thread_runqueue_wait_ns(::gettid()) >= first);
  CHECK(thread_runqueue_wait_ns(999'999'999) == -1);  // no such thread
}
