// The dashboard end to end in a real browser (issue 16, item 4): hvac-twin-sim with a leaking
// heat pump, hvac-twind estimating it at 30x real time, hvac-twin-web serving 127.0.0.1, and
// Debian's headless Chromium driven by browser/dashboard_check.py (python3-selenium): the tile
// appears and updates within 1 s of each cycle's stamp, the unit view draws, the leak turns the
// tile LEAK, the killed daemon turns it stale within the liveliness lease, and the console stays
// free of errors. The leak detector is compressed as in leak_alarm_test, further: warm-up and
// references 2 min each and a decision per minute of model time, the leak 300 g/h from 3 min,
// so LEAK comes about a minute after the start.
// What would fail: a page that does not update, a server that does not push, a stale state
// never shown (or shown late), a script error, a tile that shows the state by colour only.
#include <catch2/catch.hpp>
#include <chrono>
#include <csignal>
#include <string>

#include "stack.hpp"

using namespace hvac_twin;
using namespace hvac_twin::test;
using namespace std::chrono_literals;

namespace {

constexpr int kDomain = 200;  // hvac-twin-web's range (200..209)
constexpr double kTimeScale = 30.0;
constexpr double kPeriodS = 5.0;

StackOptions leaking_heat_pump() {
  StackOptions o;
  o.domain_id = kDomain;
  o.time_scale = kTimeScale;  // 167 ms of wall time per cycle (leak_alarm_test: why not 60x)
  o.period_s = kPeriodS;
  o.deadline_s = 0.16;
  o.poll_period_s = 0.02;
  o.sim_step_s = 1.0;
  o.base_config = "config/demo-heat-pump.json";
  o.sim_args = {"--leak", "300@0.05"};
  o.customize = [](nlohmann::json& c) {
    auto& e = c["units"][0]["estimator"];
    e["settle_s"] = 300.0;
    e["checkpoint_every_cycles"] = 0;
    e["leak_detection"] = {{"warm_up_s", 120.0},
                           {"reference_s", 120.0},
                           {"interval_s", 60.0},
                           {"startup_s", 0.0},
                           {"charge_allowance", 0.02}};
  };
  return o;
}

}  // namespace

TEST_CASE("the dashboard in a real browser: live tile, LEAK, stale on a killed daemon",
          "[integration][browser]") {
  Stack stack("web-browser", leaking_heat_pump());
  Process web(HVAC_TWIN_WEB_EXE, {"--domain", std::to_string(kDomain), "--listen", "127.0.0.1:0"},
              stack.path("web.out"), stack.path("web.err"));
  std::optional<std::vector<std::string>> served;
  REQUIRE(eventually(
      [&] {
        return (served = regex_find(web.err(), R"(serving (http://127\.0\.0\.1:\d+/))"))
            .has_value();
      },
      20s));
  const std::string url = (*served)[1];
  stack.start_sim();
  stack.start_daemon();

  const double period_ms = kPeriodS / kTimeScale * 1000.0;
  Process browser(
      "/usr/bin/python3",
      {std::string(HVAC_TWIN_SOURCE_DIR) + "/tests/integration/browser/dashboard_check.py", "--url",
       url, "--daemon-pid", std::to_string(stack.daemon().pid()), "--period-ms",
       std::to_string(period_ms), "--out-dir", stack.path("")},
      stack.path("browser.out"), stack.path("browser.err"));
  const auto status = browser.wait(240s);
  INFO("browser check:\n" << browser.err() << "\nfigures: " << browser.out());
  INFO("daemon stderr (tail):\n"
       << stack.daemon().err().substr(
              stack.daemon().err().size() > 3000 ? stack.daemon().err().size() - 3000 : 0));
  INFO("hvac-twin-web stderr:\n" << web.err());
  REQUIRE(status.has_value());
  CHECK(*status == 0);
  // The script killed the daemon itself (SIGKILL), as the stale check needs.
  CHECK(stack.daemon().wait(5s) == 128 + SIGKILL);
  // hvac-twin-web stops cleanly.
  web.signal(SIGTERM);
  CHECK(web.wait(10s) == 0);
}
