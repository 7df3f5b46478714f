#include "daemon/runtime/supervisor.hpp"

#include <atomic>
#include <catch2/catch.hpp>
#include <chrono>
#include <cstdlib>
#include <thread>

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
