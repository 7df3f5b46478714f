// hvac-twind inside its unit's seccomp sandbox, without a running systemd: the test reads
// RestrictAddressFamilies= and SystemCallFilter= from systemd/hvac-twind.service, expands the
// system-call groups with systemd-analyze, and runs the daemon under hvac-twin-test-sandbox,
// which applies both with seccomp (a refused system call kills the daemon, so none goes
// unnoticed). The daemon starts, notifies, reads Modbus, publishes and shuts down cleanly; without
// AF_NETLINK it stops at start-up with a message that names it. hvac-twin-web, under its own
// unit's filters, reads the daemon's DDS topics and serves the page and API.
#include <httplib.h>

#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "tests/integration/stack.hpp"
#include "tests/integration/systemd_support.hpp"
#include "tests/support/notify_socket.hpp"

using namespace hvac_twin::test;
using namespace std::chrono_literals;

namespace {

// In an AddressSanitizer build, LeakSanitizer's check at exit stops the process's threads with
// ptrace(), which the unit forbids (the production binary has no sanitizer). The sandboxed
// daemon runs without that one check; every other test still checks for leaks.
#if defined(__SANITIZE_ADDRESS__)
constexpr bool kLeakCheckNeedsPtrace = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kLeakCheckNeedsPtrace = true;
#else
constexpr bool kLeakCheckNeedsPtrace = false;
#endif
#else
constexpr bool kLeakCheckNeedsPtrace = false;
#endif

std::map<std::string, std::vector<std::string>> shipped_unit() {
  return parse_unit(std::string(HVAC_TWIN_SOURCE_DIR) + "/systemd/hvac-twind.service");
}

// "AF_UNIX AF_INET" -> "AF_UNIX,AF_INET", without `drop`.
std::string families(const std::string& unit_value, const std::string& drop = "") {
  std::istringstream words(unit_value);
  std::string word, out;
  while (words >> word) {
    if (word == drop) continue;
    if (!out.empty()) out += ",";
    out += word;
  }
  return out;
}

std::unique_ptr<Process> start_sandboxed_daemon(Stack& stack, const std::vector<std::string>& jail,
                                                const std::vector<std::string>& env) {
  stack.write_config(stack.port() == 0 ? 1 : stack.port());
  std::vector<std::string> args = jail;
  if (kLeakCheckNeedsPtrace) {
    const char* asan = std::getenv("ASAN_OPTIONS");
    args.insert(args.end(), {"--setenv", std::string("ASAN_OPTIONS=") + (asan ? asan : "") +
                                             ":detect_leaks=0"});
  }
  args.insert(args.end(), {"--", HVAC_TWIND_EXE, "--config", stack.path("config.json")});
  return std::make_unique<Process>(HVAC_TWIN_SANDBOX_EXE, args, stack.path("daemon.out"),
                                   stack.path("daemon.err"), env);
}

}  // namespace

TEST_CASE("hvac-twind works under the unit's address-family and system-call filters",
          "[integration][systemd][sandbox]") {
  const auto unit = shipped_unit();
  REQUIRE(unit.count("Service.RestrictAddressFamilies") == 1);
  REQUIRE(unit.count("Service.SystemCallFilter") == 1);
  const std::set<std::string> syscalls = allowed_syscalls(unit.at("Service.SystemCallFilter"));
  // The groups expanded as systemd does: networking allowed, privileged and priority calls not.
  REQUIRE(syscalls.count("connect") == 1);
  REQUIRE(syscalls.count("setuid") == 0);
  REQUIRE(syscalls.count("sched_setscheduler") == 0);

  // The built-in zone model, and the same model as an FMU: dlopen() of the binary the daemon
  // unpacked into its state directory passes the same filters.
  for (const bool fmu : {false, true}) {
    INFO((fmu ? "zone model as an FMU" : "built-in zone model"));
    auto options = zone_stack_options(fmu ? 89 : 60);
    if (fmu)
      options.daemon_customize = [](nlohmann::json& c) {
        c["units"][0]["model"]["type"] = "fmu";
        c["units"][0]["model"]["fmu"] = std::string(HVAC_TWIN_BINARY_DIR) + "/fmu/zone_rc.fmu";
      };
    Stack stack(fmu ? "sandbox-fmu" : "sandbox", options);
    const std::string list = stack.path("syscalls.txt");
    {
      std::ofstream out(list);
      for (const auto& s : syscalls)
        out << s << "\n";
    }
    stack.start_sim();
    NotifySocket systemd;
    auto daemon = start_sandboxed_daemon(
        stack,
        {"--address-families", families(unit.at("Service.RestrictAddressFamilies").back()),
         "--syscalls", list},
        {"NOTIFY_SOCKET=" + systemd.path(), "WATCHDOG_USEC=2000000"});
    INFO("daemon log:\n" << daemon->err());
    REQUIRE(!systemd.receive(10s, "READY=1").empty());
    stack.start_echo(30.0);

    // Modbus read and estimates published: GOOD observations arrive at a subscriber outside. The
    // notifications are read all along, as systemd does (a full socket would block the daemon).
    int pings = 0;
    const bool published = eventually(
        [&] {
          for (const auto& m : systemd.receive(50ms))
            if (m == "WATCHDOG=1") ++pings;
          for (const auto& s : stack.samples())
            if (s["topic"] == "observation" && s["quality"] == "GOOD") return pings >= 2;
          return false;
        },
        15s);
    INFO("WATCHDOG=1 received " << pings << " times");
    CHECK(published);
    CHECK(daemon->running());

    daemon->signal(SIGTERM);
    const auto rc = daemon->wait(5s);
    REQUIRE(rc.has_value());
    CHECK(*rc == 0);  // 159 would be SIGSYS: a system call the unit forbids
    if (fmu) CHECK_THAT(daemon->err(), Catch::Contains("model FMU"));
  }
}

TEST_CASE("without AF_NETLINK hvac-twind stops at start-up and says why",
          "[integration][systemd][sandbox]") {
  const auto unit = shipped_unit();
  const std::string allowed =
      families(unit.at("Service.RestrictAddressFamilies").back(), "AF_NETLINK");
  REQUIRE(allowed == "AF_UNIX,AF_INET,AF_INET6");
  Stack stack("sandbox-nonetlink", zone_stack_options(61));
  NotifySocket systemd;
  auto daemon = start_sandboxed_daemon(stack, {"--address-families", allowed},
                                       {"NOTIFY_SOCKET=" + systemd.path()});
  const auto rc = daemon->wait(10s);
  const std::string err = daemon->err();
  INFO("daemon log:\n" << err);
  REQUIRE(rc.has_value());
  CHECK(*rc == 1);
  CHECK_THAT(err, Catch::Contains("start-up failed"));
  CHECK_THAT(err, Catch::Contains("may not open AF_NETLINK sockets"));
  CHECK_THAT(err, Catch::Contains("RestrictAddressFamilies="));
  const auto notes = systemd.receive(200ms);
  CHECK(std::find(notes.begin(), notes.end(), "READY=1") == notes.end());
}

TEST_CASE("hvac-twin-web works under its unit's address-family and system-call filters",
          "[integration][systemd][sandbox][web]") {
  const auto unit =
      parse_unit(std::string(HVAC_TWIN_SOURCE_DIR) + "/systemd/hvac-twin-web.service");
  REQUIRE(unit.count("Service.RestrictAddressFamilies") == 1);
  const std::set<std::string> syscalls = allowed_syscalls(unit.at("Service.SystemCallFilter"));
  REQUIRE(syscalls.count("accept4") == 1);
  REQUIRE(syscalls.count("setuid") == 0);
  constexpr int kDomain = 203;  // hvac-twin-web's range (200..209)
  Stack stack("sandbox-web", zone_stack_options(kDomain));
  const std::string list = stack.path("web-syscalls.txt");
  {
    std::ofstream out(list);
    for (const auto& s : syscalls)
      out << s << "\n";
  }
  stack.start_sim();
  stack.start_daemon();
  std::vector<std::string> args{"--address-families",
                                families(unit.at("Service.RestrictAddressFamilies").back()),
                                "--syscalls", list};
  if (kLeakCheckNeedsPtrace) {
    const char* asan = std::getenv("ASAN_OPTIONS");
    args.insert(args.end(), {"--setenv", std::string("ASAN_OPTIONS=") + (asan ? asan : "") +
                                             ":detect_leaks=0"});
  }
  args.insert(args.end(), {"--", HVAC_TWIN_WEB_EXE, "--domain", std::to_string(kDomain), "--listen",
                           "127.0.0.1:0"});
  Process web(HVAC_TWIN_SANDBOX_EXE, args, stack.path("web.out"), stack.path("web.err"));
  std::optional<std::vector<std::string>> served;
  REQUIRE(eventually(
      [&] {
        return (served = regex_find(web.err(), R"(serving http://127\.0\.0\.1:(\d+)/)"))
            .has_value();
      },
      20s));
  INFO("hvac-twin-web log:\n" << web.err());
  // The daemon's unit reaches the sandboxed dashboard over DDS, and the page and API over HTTP.
  httplib::Client http("127.0.0.1", std::stoi((*served)[1]));
  http.set_read_timeout(5, 0);
  const bool unit_shown = eventually(
      [&] {
        const auto r = http.Get("/api/overview");
        return r && r->status == 200 && nlohmann::json::parse(r->body)["units"].size() == 1;
      },
      20s);
  CHECK(unit_shown);
  const auto page = http.Get("/");
  REQUIRE(page);
  CHECK(page->status == 200);
  CHECK(web.running());
  web.signal(SIGTERM);
  const auto rc = web.wait(10s);
  REQUIRE(rc.has_value());
  CHECK(*rc == 0);  // 159 would be SIGSYS: a system call the unit forbids
}
