// A device that disappears: the simulator is stopped mid-run. The daemon must keep running and
// publishing, show the outage in the points' quality and in the estimates (DEGRADED,
// predict-only), and be back to GOOD within one reconnect back-off cap of the device's return.
#include <catch2/catch.hpp>
#include <thread>

#include "daemon/runtime/clock.hpp"
#include "tests/integration/stack.hpp"

using namespace hvac_twin::test;
using namespace std::chrono_literals;

namespace {

// The newest sample of `topic` whose `key` field equals `name`, published after `after_ns`.
nlohmann::json newest(const std::vector<nlohmann::json>& samples, const std::string& topic,
                      const std::string& key, const std::string& name, std::int64_t after_ns) {
  nlohmann::json found;
  for (const auto& s : samples)
    if (s["topic"] == topic && (key.empty() || s[key] == name) &&
        s["timestamp_ns"].get<std::int64_t>() > after_ns)
      found = s;
  return found;
}

}  // namespace

TEST_CASE("the daemon rides out a device outage and recovers within one back-off cap",
          "[integration][outage]") {
  StackOptions o;
  o.domain_id = 52;
  o.time_scale = 600.0;
  o.period_s = 60.0;  // 0.1 s wall
  o.poll_period_s = 0.05;
  Stack stack("outage", o);
  const int port = stack.start_sim();
  stack.start_daemon();
  stack.start_echo(60.0);
  const auto t0 = hvac_twin::runtime::realtime_ns();
  REQUIRE(eventually(
      [&] {
        auto obs = newest(stack.samples(), "observation", "point", "zone_temp", t0);
        return obs.is_object() && obs["quality"] == "GOOD" && obs["fused"] == true;
      },
      15s));

  // The device goes away.
  stack.stop_sim();
  const auto down = hvac_twin::runtime::realtime_ns();
  REQUIRE(eventually(
      [&] {
        const auto s = stack.samples();
        auto obs = newest(s, "observation", "point", "zone_temp", down);
        auto est = newest(s, "virtual_sensor", "name", "mass_temperature", down);
        auto health = newest(s, "estimator_health", "", "", down);
        return obs.is_object() && obs["quality"] == "COMM_FAIL" && obs["fused"] == false &&
               est.is_object() && est["quality"] == "DEGRADED" &&
               (est["flags"].get<int>() & 1) != 0 && health.is_object() &&
               health["modbus_connected"] == false;
      },
      10s));
  // ... and the daemon keeps running and publishing for a few seconds.
  std::this_thread::sleep_for(3s);
  REQUIRE(stack.daemon().running());
  const auto still = hvac_twin::runtime::realtime_ns() - 1'000'000'000;
  CHECK(newest(stack.samples(), "estimator_health", "", "", still).is_object());

  // The device returns on the same port.
  stack.start_sim(port);
  const auto up = hvac_twin::runtime::realtime_ns();
  std::int64_t good_at = 0;
  REQUIRE(eventually(
      [&] {
        auto obs = newest(stack.samples(), "observation", "point", "zone_temp", up);
        if (obs.is_object() && obs["quality"] == "GOOD" && obs["fused"] == true)
          good_at = obs["timestamp_ns"];
        return good_at != 0;
      },
      20s));
  const double recovery_s = static_cast<double>(good_at - up) * 1e-9;
  INFO("recovered " << recovery_s << " s after the device returned");
  // Back-off cap (5 s) + one poll + one cycle; a little slack for a loaded machine.
  CHECK(recovery_s < 5.0 + 0.05 + 0.1 + 0.5);
  CHECK(eventually(
      [&] {
        auto e = newest(stack.samples(), "virtual_sensor", "name", "mass_temperature", good_at);
        return e.is_object() && e["quality"] == "GOOD";
      },
      5s));

  stack.daemon().signal(SIGTERM);
  const auto rc = stack.daemon().wait(5s);
  REQUIRE(rc.has_value());
  CHECK(*rc == 0);
}
