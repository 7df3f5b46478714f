// hvac-twind as a service manager sees it: configuration errors exit 78 with every error at its
// JSON pointer and without READY=1; READY=1 after start-up and WATCHDOG=1 only from completed
// cycles, at least every half WatchdogSec; a hung cycle stops the pings at once (well within one
// WatchdogSec) and the daemon exits 70 after its hang timeout; repeated overruns stop the pings;
// SIGTERM shuts down cleanly within one period, also while the configuration still loads and
// when the reader of its log is gone; several units fall due spread over their period.
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/syscall.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <map>
#include <thread>
#include <vector>

#include "tests/integration/stack.hpp"
#include "tests/integration/strace_support.hpp"
#include "tests/support/notify_socket.hpp"

using namespace hvac_twin::test;
using namespace std::chrono_literals;

namespace {

std::string source(const std::string& file) {
  return std::string(HVAC_TWIN_SOURCE_DIR) + "/" + file;
}

// Times [s since `start`] at which each WATCHDOG=1 arrived.
std::vector<double> watchdog_times(NotifySocket& socket, std::chrono::milliseconds listen) {
  std::vector<double> times;
  const auto start = std::chrono::steady_clock::now();
  const auto end = start + listen;
  while (std::chrono::steady_clock::now() < end) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        end - std::chrono::steady_clock::now());
    for (const auto& m : socket.receive(std::min(left, std::chrono::milliseconds(50))))
      if (m == "WATCHDOG=1")
        times.push_back(
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  return times;
}

// The first number of /proc/PID/FILE (the current system call in "syscall"), or -1.
long proc_number(pid_t pid, const char* file) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/" + file);
  long n = -1;
  f >> n;
  return n;
}

// SIGTERM is in the process's blocked mask (SigBlk of /proc/PID/status).
bool sigterm_blocked(pid_t pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("SigBlk:", 0) == 0)
      return (std::stoull(line.substr(7), nullptr, 16) >> (SIGTERM - 1)) & 1U;
  return false;
}

double largest_gap(const std::vector<double>& t, double from) {
  double gap = 0.0, last = from;
  for (double x : t) {
    gap = std::max(gap, x - last);
    last = x;
  }
  return gap;
}

}  // namespace

TEST_CASE("check-config names every error by JSON pointer and exits 78", "[integration][cli]") {
  const std::string dir = std::filesystem::temp_directory_path().string();
  Process bad(HVAC_TWIND_EXE, {"--check-config", source("config/examples/several-errors.json")},
              dir + "/cc-bad.out", dir + "/cc-bad.err");
  REQUIRE(bad.wait(10s) == 78);
  const std::string err = bad.err();
  CHECK_THAT(err, Catch::Contains("/units/0/modbus/port: expected an integer in [1, 65535]"));
  CHECK_THAT(err, Catch::Contains("/units/0/points/2/type: expected one of"));
  CHECK_THAT(err, Catch::Contains("/units/0/points/1: missing required field \"signal\""));
  CHECK_THAT(err, Catch::Contains("error(s)"));

  Process good(HVAC_TWIND_EXE, {"--check-config", source("config/demo.json")}, dir + "/cc-good.out",
               dir + "/cc-good.err");
  REQUIRE(good.wait(10s) == 0);
  CHECK_THAT(good.out(), Catch::Contains("valid"));

  // Started as a service with a bad file, it refuses to start with the same status and never
  // tells systemd it is ready (RestartPreventExitStatus=78 then keeps it down).
  NotifySocket systemd;
  Process daemon(HVAC_TWIND_EXE, {"--config", source("config/examples/several-errors.json")},
                 dir + "/cc-d.out", dir + "/cc-d.err", {"NOTIFY_SOCKET=" + systemd.path()});
  REQUIRE(daemon.wait(10s) == 78);
  CHECK_THAT(daemon.err(), Catch::Contains("not starting"));
  CHECK(systemd.receive(100ms).empty());
}

TEST_CASE("READY=1 after start-up, WATCHDOG=1 from completed cycles, clean SIGTERM",
          "[integration][systemd]") {
  Stack stack("notify", zone_stack_options(53));
  stack.start_sim();
  NotifySocket systemd;
  stack.start_daemon({}, {"NOTIFY_SOCKET=" + systemd.path(), "WATCHDOG_USEC=2000000"});
  const auto ready = systemd.receive(10s, "READY=1");
  REQUIRE(!ready.empty());
  CHECK(ready.back() == "READY=1");
  // WatchdogSec = 2 s: pings at least every half of it (rate-limited to an eighth, 0.25 s).
  const auto pings = watchdog_times(systemd, 4s);
  INFO("pings: " << pings.size() << ", largest gap " << largest_gap(pings, 0.0) << " s");
  CHECK(pings.size() >= 5);
  CHECK(largest_gap(pings, 0.0) <= 1.0);

  const auto before = std::chrono::steady_clock::now();
  stack.daemon().signal(SIGTERM);
  const auto rc = stack.daemon().wait(5s);
  const double took =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - before).count();
  REQUIRE(rc.has_value());
  CHECK(*rc == 0);
  INFO("shut down in " << took << " s");
  CHECK(took < 0.5);  // within one (wall) period
  const auto bye = systemd.receive(1s, "STOPPING=1");
  CHECK(std::find(bye.begin(), bye.end(), "STOPPING=1") != bye.end());
}

TEST_CASE("a daemon whose log reader is gone shuts down cleanly, not by SIGPIPE",
          "[integration][cli]") {
  // Issue 17: Ctrl-C on the demo ended its `sed`, which read the daemon's stderr, first; the
  // daemon's shut-down log line then killed it by SIGPIPE (status 141) in the middle of its
  // shut-down. Here its stderr is a FIFO whose only reader the test closes.
  Stack stack("sigpipe", zone_stack_options(73));
  stack.start_sim();
  const std::string fifo = stack.path("daemon.err");
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  const int reader = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);  // not the daemon's
  REQUIRE(reader >= 0);
  NotifySocket systemd;
  stack.start_daemon({}, {"NOTIFY_SOCKET=" + systemd.path()});
  REQUIRE(!systemd.receive(10s, "READY=1").empty());
  ::close(reader);
  std::this_thread::sleep_for(1s);  // cycles on, their log lines (if any) into the broken pipe
  stack.daemon().signal(SIGTERM);   // "SIGTERM received, shutting down" into the broken pipe
  const auto rc = stack.daemon().wait(5s);
  REQUIRE(rc.has_value());
  CHECK(*rc == 0);
  CHECK(!systemd.receive(1s, "STOPPING=1").empty());
}

TEST_CASE("SIGTERM while the configuration loads: exit 0 and a log line", "[integration][cli]") {
  // Issue 17: the signals were blocked only after the configuration had loaded, so a SIGTERM in
  // the first milliseconds after exec killed the daemon (status 143, nothing logged). strace
  // holds the daemon inside its open() of the configuration file for 2 s, which makes the window
  // deterministic: the SIGTERM arrives while the configuration loads.
  if (!strace_works()) {
    WARN("SKIPPED: strace is missing or cannot trace here (.ci/setup installs it)");
    return;
  }
  StackOptions o;
  o.domain_id = 71;
  // No device: the daemon must not get as far as needing one.
  o.customize = [](nlohmann::json& c) { c["units"][0]["modbus"]["port"] = 1; };
  Stack stack("sigterm-loading", o);
  const std::string config = stack.path("config.json");
  stack.start_daemon_under({"/usr/bin/strace", "-qq", "-o", "/dev/null", "-E",
                            "ASAN_OPTIONS=detect_leaks=0", "-e", "trace=openat", "-e",
                            "inject=openat:delay_exit=2000000", "-P", config});
  pid_t daemon = 0;
  const auto in_openat = [&] {
    daemon = first_child(stack.daemon().pid());
    return daemon > 0 && proc_number(daemon, "syscall") == SYS_openat;
  };
  // In the delayed openat of the configuration, not in one of the dynamic loader's before main
  // (they take microseconds; a SIGTERM there has its default action: status 143, seen once in
  // CI): still in openat 300 ms later.
  REQUIRE(eventually(
      [&] {
        if (!in_openat()) return false;
        std::this_thread::sleep_for(300ms);
        return in_openat();
      },
      10s));
  ::kill(daemon, SIGTERM);
  const auto rc = stack.daemon().wait(10s);  // strace exits with the daemon's status
  INFO("daemon stderr:\n" << stack.daemon().err());
  REQUIRE(rc.has_value());
  CHECK(*rc == 0);
  CHECK_THAT(stack.daemon().err(), Catch::Contains("SIGTERM received"));
}

TEST_CASE("SIGTERM as soon as the daemon runs main: exit 0 and a log line", "[integration][cli]") {
  // Without strace: the SIGTERM goes out within a fraction of a millisecond of main blocking it
  // (polled in /proc), before the configuration has loaded or the units have started. (Before
  // main the dynamic loader runs for a few ms; a signal then still has its default action.)
  StackOptions o;
  o.domain_id = 72;
  Stack stack("sigterm-early", o);
  stack.write_config(1);  // no device: the daemon must not get as far as needing one
  Process daemon(HVAC_TWIND_EXE, {"--config", stack.path("config.json")}, stack.path("daemon.out"),
                 stack.path("daemon.err"));
  const auto end = std::chrono::steady_clock::now() + 10s;
  bool blocked = false;
  while (!(blocked = sigterm_blocked(daemon.pid())) && std::chrono::steady_clock::now() < end)
    std::this_thread::sleep_for(100us);
  daemon.signal(SIGTERM);
  const auto rc = daemon.wait(10s);
  INFO("daemon stderr:\n" << daemon.err());
  REQUIRE(blocked);
  REQUIRE(rc.has_value());
  CHECK(*rc == 0);
  CHECK_THAT(daemon.err(), Catch::Contains("SIGTERM received"));
}

TEST_CASE("a hung cycle stops the pings within one WatchdogSec, then the daemon exits 70",
          "[integration][systemd]") {
  StackOptions o;
  o.domain_id = 54;
  o.time_scale = 60.0;
  o.period_s = 12.0;  // 0.2 s wall
  o.poll_period_s = 0.05;
  o.customize = [](nlohmann::json& c) { c["runtime"]["hang_timeout_s"] = 2.0; };
  Stack stack("hang", o);
  stack.start_sim();
  NotifySocket systemd;
  constexpr double kWatchdogSec = 1.0;
  stack.start_daemon({"--fault-hang-at-cycle", "10"},
                     {"NOTIFY_SOCKET=" + systemd.path(), "WATCHDOG_USEC=1000000"});
  REQUIRE(!systemd.receive(10s, "READY=1").empty());

  // Play systemd for 6 s: note every WATCHDOG=1, when the cycle hangs (the fault hook logs it)
  // and when the daemon exits.
  const auto start = std::chrono::steady_clock::now();
  const auto since = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  std::vector<double> pings;
  double hang_at = -1.0, exit_at = -1.0;
  while (since() < 6.0) {
    for (const auto& m : systemd.receive(20ms))
      if (m == "WATCHDOG=1") pings.push_back(since());
    if (hang_at < 0 && stack.daemon().err().find("fault hook: cycle") != std::string::npos)
      hang_at = since();
    if (exit_at < 0 && !stack.daemon().running()) exit_at = since();
  }
  const auto rc = stack.daemon().wait(5s);
  std::string times;
  for (double t : pings)
    times += std::to_string(t).substr(0, 5) + " ";
  INFO("pings at " << times << "s; hang at " << hang_at << " s; exit at " << exit_at
                   << " s; daemon log:\n"
                   << stack.daemon().err());
  REQUIRE(hang_at > 0.0);
  REQUIRE(pings.size() >= 3);
  // Until the hang, a ping at least every half WatchdogSec.
  CHECK(largest_gap(pings, 0.0) <= kWatchdogSec / 2);
  // The pings stop at the hang (20 ms of polling slack on each side) and never resume...
  CHECK(pings.back() <= hang_at + 0.05);
  CHECK(pings.back() >= hang_at - kWatchdogSec / 2);
  // ...so a systemd with WatchdogSec=1s would act one WatchdogSec after the last ping, long before
  // the daemon's own hang timeout (2 s) makes it exit with 70.
  REQUIRE(exit_at > 0.0);
  CHECK(exit_at - pings.back() > kWatchdogSec);
  REQUIRE(rc.has_value());
  CHECK(*rc == 70);
  CHECK_THAT(stack.daemon().err(), Catch::Contains("hung"));
}

TEST_CASE("repeated overruns degrade the estimates and stop the pings", "[integration][systemd]") {
  StackOptions o;
  o.domain_id = 55;
  o.time_scale = 60.0;
  o.period_s = 12.0;  // 0.2 s wall
  o.deadline_s = 0.05;
  o.poll_period_s = 0.05;
  Stack stack("overrun", o);
  stack.start_sim();
  NotifySocket systemd;
  stack.start_daemon({"--fault-cycle-delay-ms", "80"},
                     {"NOTIFY_SOCKET=" + systemd.path(), "WATCHDOG_USEC=1000000"});
  stack.start_echo(20.0);
  REQUIRE(!systemd.receive(10s, "READY=1").empty());
  const auto pings = watchdog_times(systemd, 3s);
  CHECK(pings.size() <= 3);  // the first cycles may ping before the limit of 3 in a row
  REQUIRE(eventually(
      [&] {
        for (const auto& s : stack.samples())
          if (s["topic"] == "estimator_health" && s["overruns"].get<int>() >= 5) return true;
        return false;
      },
      10s));
  // Late, so DEGRADED with the deadline-overrun flag, but not predict-only: a late cycle still
  // fuses its measurements (it used to skip its update).
  int late_fused = 0, late_predict_only = 0;
  for (const auto& s : stack.samples())
    if (s["topic"] == "virtual_sensor" && s["quality"] == "DEGRADED" &&
        (s["flags"].get<int>() & 0x20) != 0)  // deadline_overrun
      ((s["flags"].get<int>() & 0x01) != 0 ? late_predict_only : late_fused) += 1;
  INFO("late samples: " << late_fused << " with points fused, " << late_predict_only
                        << " predict-only");
  CHECK(late_fused > 0);
  CHECK(late_fused > 10 * late_predict_only);
  CHECK(stack.daemon().running());  // degraded, not dead
  stack.daemon().signal(SIGTERM);
  CHECK(stack.daemon().wait(5s) == 0);
  // The log says once that the pings stopped, and why (issue 17: it said nothing).
  const std::string log = stack.daemon().err();
  INFO("daemon stderr:\n" << log);
  const auto stopped =
      log.find("watchdog pings stopped: unit zone1 overran its deadline 3 cycles in a row");
  CHECK(stopped != std::string::npos);
  CHECK(stopped == log.rfind("watchdog pings stopped"));
  CHECK_THAT(log,
             Catch::Contains("systemd restarts the service if this lasts WatchdogSec (1.000 s)"));
  // Every cycle overran: one line says so and that the rest are counted (issue 17 item 8: one
  // line per cycle, 12 000 a second at a 1 us period).
  const auto first = log.find("overran its deadline: ");
  CHECK(first != std::string::npos);
  CHECK(first == log.rfind("overran its deadline: "));
  CHECK_THAT(log, Catch::Contains("further overruns are counted"));
}

TEST_CASE("the units of one daemon fall due spread over their period", "[integration][cli]") {
  // Unit i of n is due i/n of its period after unit 0 (daemon.cpp): cycles due at one instant
  // queue behind each other on a core. Two zone units, the second served by the same simulator
  // under Modbus unit id 2; each cycle's health sample carries the cycle's wall-clock stamp.
  StackOptions o = zone_stack_options(94);
  o.customize = [](nlohmann::json& c) {
    nlohmann::json second = c["units"][0];
    second["id"] = "zone2";
    second["modbus"]["unit_id"] = 2;
    c["units"].push_back(second);
  };
  o.sim_args = {"--any-unit-id"};
  Stack stack("stagger", o);
  const auto rc = stack.run_for(0.25, {"--topics", "estimator_health"});
  INFO("daemon stderr:\n" << stack.daemon().err());
  REQUIRE(rc.has_value());
  CHECK(*rc == 0);
  std::map<std::uint64_t, std::int64_t> first, second;
  for (const auto& s : stack.samples()) {
    if (s["topic"] != "estimator_health") continue;
    auto& stamps = s["unit"] == "zone1" ? first : second;
    stamps[s["cycle"].get<std::uint64_t>()] = s["timestamp_ns"].get<std::int64_t>();
  }
  std::vector<double> lag_s;  // zone2's stamp after zone1's, same cycle
  for (const auto& [cycle, t] : first)
    if (const auto it = second.find(cycle); it != second.end())
      lag_s.push_back(static_cast<double>(it->second - t) * 1e-9);
  REQUIRE(lag_s.size() >= 15);
  std::sort(lag_s.begin(), lag_s.end());
  const double wall_period_s = o.period_s / o.time_scale;
  const double median = lag_s[lag_s.size() / 2];
  INFO("median lag " << median << " s of a " << wall_period_s << " s period");
  CHECK(median > 0.4 * wall_period_s);
  CHECK(median < 0.6 * wall_period_s);
}
