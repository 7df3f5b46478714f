// Bad register data end to end: NaN, infinities, huge, denormal and out-of-range values on the
// measured point and on the inputs, and a point that turns to garbage. The daemon skips what it
// cannot use, keeps its estimates finite, recovers when the data do, and nothing non-finite ever
// reaches the wire: the one NaN a test hook hands the publisher is dropped and counted.
#include <bit>
#include <catch2/catch.hpp>
#include <random>
#include <thread>

#include "daemon/runtime/clock.hpp"
#include "tests/integration/fault_rig.hpp"

using namespace hvac_twin::test;
using namespace hvac_twin::test_fault;
using namespace std::chrono_literals;
using hvac_twin::config::RegisterKind;
using hvac_twin::runtime::realtime_ns;

namespace {

constexpr std::uint16_t kZoneAddress = 4;  // zone_temp as float32 ABCD, input registers 4-5
constexpr std::uint16_t kHeatAddress = 2;  // hp_heat float32 CDAB, input registers 2-3
constexpr std::uint64_t kNanCycle = 25;

// A float32's bits into registers: ABCD (high word first) or CDAB.
void set_float(FaultServer& s, std::uint16_t address, float value, bool cdab) {
  const auto bits = std::bit_cast<std::uint32_t>(value);
  const auto hi = static_cast<std::uint16_t>(bits >> 16), lo = static_cast<std::uint16_t>(bits);
  const std::uint16_t regs[2] = {cdab ? lo : hi, cdab ? hi : lo};
  s.set_registers(RegisterKind::kInput, address, regs);
}
void set_zone(FaultServer& s, float v) {
  set_float(s, kZoneAddress, v, false);
}
void set_heat(FaultServer& s, float v) {
  set_float(s, kHeatAddress, v, true);
}

void serve_good(FaultServer& s) {
  set_zone(s, 21.0f);
  set_heat(s, 2.0f);
  s.set_value(demo_point("outdoor_temp"), 5.0);
}

std::vector<nlohmann::json> between(const std::vector<nlohmann::json>& samples,
                                    const std::string& topic, std::int64_t from, std::int64_t to) {
  std::vector<nlohmann::json> out;
  for (const auto& s : samples) {
    const auto t = s["timestamp_ns"].get<std::int64_t>();
    if (s["topic"] == topic && t >= from && t < to) out.push_back(s);
  }
  return out;
}

}  // namespace

TEST_CASE("bad register data never reaches the filter or the wire", "[integration][fault]") {
  FaultServer server;
  serve_good(server);
  server.start();
  FaultRigOptions o;
  o.domain_id = 83;
  o.poll_period_s = 0.1;
  o.response_timeout_s = 0.04;
  o.byte_timeout_s = 0.02;
  o.customize = [](nlohmann::json& c) {
    auto& zone = c["units"][0]["points"][0];
    zone["address"] = kZoneAddress;
    zone["type"] = "float32";
    zone.erase("scale");
    // Point ranges wider than the model's (zone air -40..70 degC, heat pump -30..30 kW): the
    // poller passes 90 degC or 80 kW as GOOD, and only the pipeline's own guard stops them.
    zone["range"] = {-100, 100};
    c["units"][0]["points"][2]["range"] = {-100, 100};
  };
  FaultRig rig("baddata", server.port(), o);
  rig.start_daemon({"--fault-nan-output-at-cycle", std::to_string(kNanCycle)});
  rig.start_echo(90.0);
  const auto good_again = [&](std::int64_t after) {
    return eventually(
        [&] {
          const auto s = rig.samples();
          const auto obs = newest(s, "observation", "point", "zone_temp", after);
          const auto est = newest(s, "virtual_sensor", "name", "mass_temperature", after);
          return obs.is_object() && obs["quality"] == "GOOD" && obs["fused"] == true &&
                 est.is_object() && est["quality"] == "GOOD";
        },
        15s);
  };
  REQUIRE(good_again(realtime_ns()));

  struct Phase {
    const char* what;
    bool zone;  // the measured point; else the input hp_heat
    float value;
    const char* quality;  // the point's expected Modbus quality
  };
  const float inf = std::numeric_limits<float>::infinity();
  const std::vector<Phase> phases = {
      {"zone NaN", true, std::numeric_limits<float>::quiet_NaN(), "OUT_OF_RANGE"},
      {"zone +Inf", true, inf, "OUT_OF_RANGE"},
      {"zone -Inf", true, -inf, "OUT_OF_RANGE"},
      {"zone huge", true, 3e38f, "OUT_OF_RANGE"},
      {"zone outside the point's range", true, 150.0f, "OUT_OF_RANGE"},
      {"zone outside the model's range", true, 90.0f, "GOOD"},
      {"zone denormal (in range, gated)", true, 1e-40f, "GOOD"},
      {"heat NaN", false, std::numeric_limits<float>::quiet_NaN(), "OUT_OF_RANGE"},
      {"heat -Inf", false, -inf, "OUT_OF_RANGE"},
      {"heat huge", false, -3e38f, "OUT_OF_RANGE"},
      {"heat outside the point's range", false, 120.0f, "OUT_OF_RANGE"},
      {"heat outside the model's range", false, 80.0f, "GOOD"},
  };
  for (const Phase& p : phases) {
    INFO("phase: " << p.what);
    if (p.zone)
      set_zone(server, p.value);
    else
      set_heat(server, p.value);
    const auto from = realtime_ns() + 400'000'000;  // a few polls to take effect
    std::this_thread::sleep_for(1200ms);
    const auto to = realtime_ns();
    const auto s = rig.samples();
    const auto obs = between(s, "observation", from, to);
    const auto est = between(s, "virtual_sensor", from, to);
    REQUIRE(!obs.empty());
    REQUIRE(!est.empty());
    for (const auto& ob : obs) {
      CHECK(ob["fused"] == !p.zone);  // a bad measurement is never fused
      if (p.zone) CHECK(ob["quality"] == p.quality);
    }
    for (const auto& e : est) {
      CHECK(e["quality"] == "DEGRADED");
      const auto flags = e["flag_names"].dump();
      if (p.zone)
        CHECK(flags.find("predict_only") != std::string::npos);
      else
        CHECK(flags.find("input_held") != std::string::npos);
    }
    serve_good(server);
    REQUIRE(good_again(realtime_ns()));
  }

  // A point that turns to garbage: random bits on the measured point for 3 s.
  std::mt19937 rng(3);
  const auto garbage_from = realtime_ns();
  for (int i = 0; i < 60; ++i) {
    const std::uint16_t regs[2] = {static_cast<std::uint16_t>(rng()),
                                   static_cast<std::uint16_t>(rng())};
    server.set_registers(RegisterKind::kInput, kZoneAddress, regs);
    std::this_thread::sleep_for(50ms);
  }
  const auto garbage_to = realtime_ns();
  serve_good(server);
  REQUIRE(good_again(realtime_ns()));

  const auto s = rig.samples();
  std::size_t non_finite = 0, fused_garbage = 0;
  for (const auto& x : s)
    if (!all_finite(x)) ++non_finite;
  for (const auto& ob : between(s, "observation", garbage_from + 300'000'000, garbage_to))
    if (ob["fused"] == true && std::abs(ob["value"].get<double>() - 21.0) > 1.0) ++fused_garbage;
  const auto health = newest(s, "estimator_health", "", "", 0);
  INFO("samples " << s.size() << "; last health " << health.dump());
  CHECK(non_finite == 0);
  CHECK(fused_garbage == 0);
  CHECK(health["numerical_resets"] == 0);
  for (const auto& e : between(s, "virtual_sensor", 0, realtime_ns()))
    CHECK(e["sigma"].get<double>() > 0.0);
  // The hook's NaN: dropped by the publisher's guard and counted, and the only one.
  CHECK(health["publish_rejections"] == 1);
  std::size_t at_nan_cycle = 0, others_at_nan_cycle = 0;
  for (const auto& e : s) {
    if (e["topic"] != "virtual_sensor" || e["cycle"] != kNanCycle) continue;
    if (e["name"] == "zone_air_temperature")
      ++at_nan_cycle;
    else
      ++others_at_nan_cycle;
  }
  CHECK(at_nan_cycle == 0);
  CHECK(others_at_nan_cycle >= 1);

  rig.daemon().signal(SIGTERM);
  const auto rc = rig.daemon().wait(5s);
  REQUIRE(rc.has_value());
  CHECK(*rc == 0);
}
