// A unit whose model is an FMU, end to end: hvac-twind loads the exported zone FMU (model.type
// "fmu"), unpacks it into its state directory, and estimates the simulated zone through it as it
// does through the built-in model; the unmeasured mass temperature follows the truth.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <string>

#include "tests/integration/stack.hpp"
#include "tests/integration/truth.hpp"
#include "tests/support/edited_fmu.hpp"
#include "tests/support/scratch_dir.hpp"

using namespace hvac_twin::test;
using namespace std::chrono_literals;

TEST_CASE("the daemon estimates the zone through the zone model exported as an FMU",
          "[integration][zone][fmi]") {
  const std::string fmu = std::string(HVAC_TWIN_BINARY_DIR) + "/fmu/zone_rc.fmu";
  StackOptions o;
  o.domain_id = 87;
  o.seed = 11;
  o.daemon_customize = [&fmu](nlohmann::json& c) {
    auto& model = c["units"][0]["model"];
    model["type"] = "fmu";
    model["fmu"] = fmu;
  };
  Stack stack("fmu-zone", o);
  const auto rc = stack.run_for(4.0, {"--topics", "virtual_sensor"}, 5s);
  const std::string log = stack.daemon().err();
  INFO("daemon stderr:\n" << log);
  REQUIRE(rc == 0);
  CHECK_THAT(log, Catch::Contains("model FMU " + fmu) &&
                      Catch::Contains("Jacobians by fmi2GetDirectionalDerivative"));
  const auto unpacked = std::filesystem::path(stack.path("state")) / "fmu" / "zone1";
  CHECK(std::filesystem::exists(unpacked / "binaries/linux64/zone_rc.so"));

  const Truth truth(stack.path("truth-1.csv"));
  int good = 0, n = 0;
  double sum_abs = 0.0;
  for (const auto& s : stack.samples()) {
    if (s["name"] != "mass_temperature") continue;
    if (s["quality"] == "GOOD") ++good;
    const auto t = s["timestamp_ns"].get<std::int64_t>();
    if (truth.model_time(t) < 3600.0) continue;
    sum_abs += std::abs(s["value"].get<double>() - truth.at(t, "state:T_mass"));
    ++n;
  }
  INFO("GOOD " << good << ", mass temperature mean |err| " << sum_abs / n << " K over " << n);
  CHECK(good > 60);
  REQUIRE(n > 40);
  CHECK(sum_abs / n < 0.5);
}

TEST_CASE("an FMU that returns fmi2Error stops its unit's estimates and nothing else",
          "[integration][zone][fmi]") {
  // The zone FMU with its first output mapped to a value reference the binary does not know:
  // the first update's fmi2GetReal returns fmi2Error. In-process isolation: the daemon reports
  // the FMU's message once, publishes no estimates for the unit, and keeps cycling (it neither
  // crashes nor restarts the estimator in a loop).
  StackOptions o;
  o.domain_id = 88;
  o.seed = 3;
  const ScratchDir dir("fmu-broken");
  const std::string fmu = dir / "broken.fmu";
  write_edited_zone_fmu(fmu, zone_fmu_first_output_ref(), "valueReference=\"9999\"");
  o.daemon_customize = [&fmu](nlohmann::json& c) {
    c["units"][0]["model"]["type"] = "fmu";
    c["units"][0]["model"]["fmu"] = fmu;
  };
  Stack stack("fmu-broken", o);
  const auto rc = stack.run_for(2.0, {"--topics", "virtual_sensor,estimator_health"}, 5s);
  const std::string log = stack.daemon().err();
  INFO("daemon stderr:\n" << log);
  REQUIRE(rc == 0);
  const auto failed = log.find("the model failed for good");
  REQUIRE(failed != std::string::npos);
  CHECK(log.find("the model failed for good", failed + 1) == std::string::npos);
  CHECK_THAT(log, Catch::Contains("no variable has value reference 9999"));
  CHECK_THAT(log, !Catch::Contains("the estimator restarts"));
  int health = 0, good = 0;
  for (const auto& s : stack.samples()) {
    if (s["topic"] == "estimator_health") ++health;
    if (s["topic"] == "virtual_sensor" && s["quality"] == "GOOD") ++good;
  }
  INFO("estimator_health samples " << health << ", GOOD estimates " << good);
  CHECK(health > 30);  // the unit kept cycling (2 h at a 120 s period: 60 cycles)
  CHECK(good == 0);
}

TEST_CASE("an FMU whose binary refuses its description is a configuration error at start-up",
          "[integration][fmi]") {
  // The description is valid (--check-config cannot run the binary, so it passes), but its GUID
  // is not the binary's: fmi2Instantiate refuses, and the daemon exits 78 naming the pointer.
  StackOptions o;
  o.domain_id = 90;
  const ScratchDir dir("fmu-guid");
  const std::string fmu = dir / "other-guid.fmu";
  const std::string xml = zone_fmu_description();
  const auto guid = xml.find("guid=\"{") + 7;
  write_edited_zone_fmu(fmu, "guid=\"{" + xml.substr(guid, 8), "guid=\"{00000000");
  o.daemon_customize = [&fmu](nlohmann::json& c) {
    c["units"][0]["model"]["type"] = "fmu";
    c["units"][0]["model"]["fmu"] = fmu;
  };
  Stack stack("fmu-guid", o);
  stack.write_config(1);
  Process check(HVAC_TWIND_EXE, {"--check-config", stack.path("config.json")},
                stack.path("check.out"), stack.path("check.err"));
  CHECK(check.wait(10s) == 0);
  Process daemon(HVAC_TWIND_EXE, {"--config", stack.path("config.json")}, stack.path("daemon.out"),
                 stack.path("daemon.err"));
  const auto rc = daemon.wait(10s);
  INFO("daemon stderr:\n" << daemon.err());
  REQUIRE(rc.has_value());
  CHECK(*rc == 78);
  CHECK_THAT(daemon.err(), Catch::Contains("/units/0/model/fmu: FMU zone_rc: fmi2Instantiate "
                                           "refused") &&
                               Catch::Contains("GUID {00000000"));
}
