// A unit whose model is an FMU, end to end: hvac-twind loads the exported zone FMU (model.type
// "fmu"), unpacks it into its state directory, and estimates the simulated zone through it as it
// does through the built-in model; the unmeasured mass temperature follows the truth.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <string>

#include "tests/integration/stack.hpp"
#include "tests/integration/truth.hpp"

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
    // What the built-in model's layout carries and an FMU's description does not (fmu_model.hpp):
    // the gains' initial uncertainty. The demo sets their random walk itself.
    c["units"][0]["estimator"]["initial_std"]["Q_int"] = 300.0;
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
