// The foundation end to end: hvac-twin-sim serves a simulated zone over Modbus TCP on
// 127.0.0.1, hvac-twind estimates it with the EKF, hvac-twin-echo records the DDS samples. The
// estimated internal gains and building-mass temperature, which no sensor measures, must follow
// the simulator's truth.
//
// What "follow" means here, and why. One air-temperature sensor sees the internal gains only
// through the air's heat balance, where they are confounded with the mass temperature; the two
// separate through the mass's ~10 h time constant. The scenario steps the gains to a new level
// every 3 h (tests/simulator/zone_scenario.cpp), which a random walk tracks within 1-2 h. So the
// gains are judged in the last hour of each 3-h block from hour 6 on ("settled"): mean |error|
// below 250 W (the levels span 100-1000 W) and never beyond 3 sigma, i.e. the filter's own
// uncertainty is honest. The mass temperature is judged in the same windows: mean |error| below
// 0.3 K and within 3 sigma. Observed over several runs (stop 54): gains 143-210 W mean, at most
// 1.9-2.3 sigma; mass below 0.15 K. It runs alone (label "paced", tests/CMakeLists.txt).
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <map>
#include <thread>
#include <tuple>
#include <vector>

#include "io/dds/types.hpp"
#include "tests/integration/stack.hpp"
#include "tests/integration/truth.hpp"

using namespace hvac_twin::test;
using namespace std::chrono_literals;

namespace {

struct ErrorStats {
  int n = 0;
  double sum_abs = 0.0, max_abs = 0.0, max_ratio = 0.0, last_sigma = 0.0;
  double max_ratio_h = 0.0;  // the model time of the sample with the largest |err|/sigma [h]
  void add(double err, double sigma, double model_h) {
    ++n;
    sum_abs += std::abs(err);
    max_abs = std::max(max_abs, std::abs(err));
    if (std::abs(err) / sigma > max_ratio) {
      max_ratio = std::abs(err) / sigma;
      max_ratio_h = model_h;
    }
    last_sigma = sigma;
  }
  double mean_abs() const { return n > 0 ? sum_abs / n : 0.0; }
};

}  // namespace

TEST_CASE("estimated internal gains and mass temperature follow the simulated truth",
          "[integration][zone]") {
  StackOptions o;
  o.domain_id = 51;
  o.seed = 7;
  // Half the speed under the sanitizers: there the cycles are slow enough that the lag between
  // the simulator's clock and the daemon's (below) put one settled gains error at 3.07 sigma
  // in CI (the machine's two cores shared with other tests).
  if (HVAC_TWIN_SANITIZED_BUILD) o.time_scale = 600.0;
  Stack stack("zone", o);
  const double hours = 15.0;
  const double wall_s = hours * 3600.0 / o.time_scale;
  stack.start_sim();
  stack.start_daemon();
  stack.start_echo(wall_s + 10.0);
  std::this_thread::sleep_for(std::chrono::duration<double>(wall_s));
  REQUIRE(stack.daemon().running());
  stack.daemon().signal(SIGTERM);
  const auto rc = stack.daemon().wait(5s);
  stack.stop_sim();
  stack.echo().signal(SIGTERM);
  stack.echo().wait(5s);
  INFO("daemon stderr:\n" << stack.daemon().err());
  REQUIRE(rc.has_value());
  CHECK(*rc == 0);

  const Truth truth(stack.path("truth-1.csv"));
  const auto samples = stack.samples();
  REQUIRE(truth.size() > 100);
  ErrorStats gains, mass, air;
  int estimates = 0, good = 0;
  nlohmann::json last_health;
  // cycle -> name -> (value, sigma, quality) from virtual_sensor, to compare unit_estimate with.
  std::map<std::uint64_t, std::map<std::string, std::tuple<double, double, std::string>>> by_cycle;
  std::vector<nlohmann::json> unit_estimates;
  for (const auto& s : samples) {
    if (s["topic"] == "estimator_health") last_health = s;
    if (s["topic"] == "unit_estimate") unit_estimates.push_back(s);
    if (s["topic"] != "virtual_sensor") continue;
    const auto t = s["timestamp_ns"].get<std::int64_t>();
    const std::string name = s["name"];
    const double v = s["value"], sigma = s["sigma"];
    by_cycle[s["cycle"].get<std::uint64_t>()][name] = {v, sigma, s["quality"]};
    if (name == "zone_air_temperature") {
      ++estimates;
      if (s["quality"] == "GOOD") ++good;
    }
    const double model_t = truth.model_time(t);
    const bool settled =
        model_t >= 6.0 * 3600.0 && std::fmod(model_t, 3.0 * 3600.0) >= 2.0 * 3600.0;
    if (!settled) continue;
    const double h = model_t / 3600.0;
    if (name == "internal_gains") gains.add(v - truth.at(t, "state:Q_int"), sigma, h);
    if (name == "mass_temperature") mass.add(v - truth.at(t, "state:T_mass"), sigma, h);
    if (name == "zone_air_temperature") air.add(v - truth.at(t, "state:T_air"), sigma, h);
  }
  INFO("cycles " << estimates << ", GOOD " << good);
  INFO("internal gains: mean |err| " << gains.mean_abs() << " W, max " << gains.max_abs
                                     << " W, max |err|/sigma " << gains.max_ratio << " at "
                                     << gains.max_ratio_h << " h"
                                     << ", final sigma " << gains.last_sigma << " W");
  INFO("mass temperature: mean |err| " << mass.mean_abs() << " K, max " << mass.max_abs
                                       << " K, max |err|/sigma " << mass.max_ratio << " at "
                                       << mass.max_ratio_h << " h");
  INFO("air temperature: mean |err| " << air.mean_abs() << " K, max " << air.max_abs << " K");
  INFO("last health: " << last_health.dump());
  REQUIRE(gains.n > 60);
  // Seen, same seed: mean |err| ~143 W on an idle machine, 211-215 W with the machine loaded
  // (release) and in ASan/UBSan builds. Stop 54 measured 176 W beside two CPU hogs, 184 W with
  // the daemon stopped for 50 ms every 1.5 s, and 202 W at 600x on an idle machine: the spread
  // is not the time acceleration, and stalls of the daemon or (80 ms) of the simulator left the
  // max |err|/sigma at 2.0-2.3. One fresh-clone CI run saw 3.81 (mean 187 W) and was not
  // reproduced; the failure message gives the model hour of the worst sample. The gains levels
  // are 100-1000 W, so a broken estimator is far outside either bound.
  CHECK(gains.mean_abs() < (HVAC_TWIN_SANITIZED_BUILD ? 300.0 : 250.0));
  CHECK(gains.max_ratio < 3.0);
  CHECK(mass.mean_abs() < 0.3);
  CHECK(mass.max_ratio < 3.0);
  CHECK(air.mean_abs() < 0.05);
  // The estimator kept up: no deadline overruns, no numerical resets, (almost) all cycles GOOD.
  REQUIRE(last_health.is_object());
  CHECK(last_health["overruns"] == 0);
  CHECK(last_health["numerical_resets"] == 0);
  CHECK(good >= estimates * 95 / 100);
  // unit_estimate: one sample per cycle with every virtual sensor of that cycle, exactly as on
  // virtual_sensor (issue 17, item 12).
  int matched = 0, mismatched = 0;
  for (const auto& u : unit_estimates) {
    const auto it = by_cycle.find(u["cycle"].get<std::uint64_t>());
    if (it == by_cycle.end()) continue;  // the echo started or stopped in between
    bool same = u["estimates"].size() == it->second.size();
    for (const auto& e : u["estimates"]) {
      const auto vs = it->second.find(e["name"].get<std::string>());
      same = same && vs != it->second.end() && std::get<0>(vs->second) == e["value"] &&
             std::get<1>(vs->second) == e["sigma"] && std::get<2>(vs->second) == u["quality"];
    }
    (same ? matched : mismatched) += 1;
  }
  INFO("unit_estimate samples " << unit_estimates.size() << ": " << matched
                                << " match their cycle's "
                                << "virtual sensors, " << mismatched << " do not");
  CHECK(matched >= estimates * 9 / 10);
  CHECK(mismatched == 0);
  if (!unit_estimates.empty()) CHECK(unit_estimates.back()["estimates"].size() == 4);
}

TEST_CASE("estimator.type selects the filter the daemon runs, end to end", "[integration][zone]") {
  // Each filter on the zone model through the whole stack for 4 simulated hours: it runs,
  // publishes GOOD estimates, and the unmeasured mass temperature stays near the truth.
  for (const std::string type : {"ekf", "constrained_enkf"}) {
    StackOptions o;
    o.domain_id = 50;
    o.seed = 11;
    o.customize = [type](nlohmann::json& c) {
      c["units"][0]["estimator"]["type"] = type;
      c["units"][0]["estimator"]["ensemble_members"] = 24;
    };
    Stack stack("filter-" + type, o);
    const auto rc = stack.run_for(4.0, {"--topics", "virtual_sensor"}, 5s);
    INFO(type << ": daemon stderr:\n" << stack.daemon().err());
    REQUIRE(rc == 0);
    CHECK_THAT(stack.daemon().err(), Catch::Contains("filter " + type));
    const Truth truth(stack.path("truth-1.csv"));
    ErrorStats mass;
    int good = 0;
    std::vector<bool> cold;  // per mass_temperature sample: flagged cold_start
    for (const auto& s : stack.samples()) {
      if (s["name"] != "mass_temperature") continue;
      if (s["quality"] == "GOOD") ++good;
      cold.push_back((s["flags"].get<std::uint32_t>() & hvac_twin::dds::kFlagColdStart) != 0);
      const auto t = s["timestamp_ns"].get<std::int64_t>();
      const double model_t = truth.model_time(t);
      if (model_t < 3600.0) continue;
      mass.add(s["value"].get<double>() - truth.at(t, "state:T_mass"), s["sigma"],
               model_t / 3600.0);
    }
    INFO("GOOD " << good << ", mass temperature mean |err| " << mass.mean_abs() << " K");
    CHECK(good > 60);
    REQUIRE(mass.n > 40);
    CHECK(mass.mean_abs() < 0.5);
    // Started cold, the estimates say so until the filter has converged (after its 600 s
    // parameter hold, every point fused 12 updates in a row), then never again in this run.
    const auto first_warm = std::find(cold.begin(), cold.end(), false);
    INFO("cold_start on " << first_warm - cold.begin() << " of " << cold.size() << " samples");
    REQUIRE(!cold.empty());
    CHECK(cold.front());
    CHECK(first_warm != cold.end());
    CHECK(std::find(first_warm, cold.end(), true) == cold.end());
    CHECK_THAT(stack.daemon().err(), Catch::Contains("flag cold_start cleared"));
  }
}

TEST_CASE("a frozen zone sensor is STUCK, not fused, logged once, and usable again when it moves",
          "[integration][zone][stuck]") {
  // Issue 17 item 3: a dead transmitter holding its last value was fused as GOOD. The simulator
  // serves zone_temp at a fixed 21.0 degC from hour 1 to hour 2.5 (hvac-twin-sim --point) while
  // the zone, heated and cooling, moves; stuck_after_s 600 (model seconds).
  StackOptions o;
  o.domain_id = 68;
  o.seed = 5;
  const double frozen_from_h = 1.0, frozen_to_h = 2.5, end_h = 4.0;
  o.sim_args = {"--point", "zone_temp=21.0@" + std::to_string(frozen_from_h) + "-" +
                               std::to_string(frozen_to_h)};
  o.customize = [](nlohmann::json& c) { c["units"][0]["points"][0]["stuck_after_s"] = 600.0; };
  Stack stack("stuck", o);
  const auto rc = stack.run_for(end_h, {"--topics", "observation"}, 5s);
  const std::string log = stack.daemon().err();
  INFO("daemon stderr:\n" << log);
  REQUIRE(rc == 0);

  const Truth truth(stack.path("truth-1.csv"));
  int stuck = 0, stuck_fused = 0, stuck_outside = 0, after = 0, after_fused = 0;
  int after_not_good = 0;
  double first_stuck_h = 1e9;
  for (const auto& s : stack.samples()) {
    if (s["topic"] != "observation" || s["point"] != "zone_temp") continue;
    const double h = truth.model_time(s["timestamp_ns"].get<std::int64_t>()) / 3600.0;
    if (s["quality"] == "STUCK") {
      ++stuck;
      stuck_fused += s["fused"].get<bool>() ? 1 : 0;
      // A cycle or two either side: the poll and the cycle are not aligned with the truth.
      if (h < frozen_from_h || h > frozen_to_h + 0.1) ++stuck_outside;
      first_stuck_h = std::min(first_stuck_h, h);
    } else if (h > frozen_to_h + 0.25) {
      // Usable again: a reading polled in time is fused. One the poll did not bring in time
      // (STALE: a host that stalls the 0.1 s wall period, seen once in CI with 4 of 37 so) is
      // not fused by design, and is counted apart.
      if (s["quality"] != "GOOD") {
        ++after_not_good;
        continue;
      }
      ++after;
      after_fused += s["fused"].get<bool>() ? 1 : 0;
    }
  }
  INFO("STUCK " << stuck << " (fused " << stuck_fused << ", outside the window " << stuck_outside
                << "), first at " << first_stuck_h << " h; after the window " << after
                << " good samples, fused " << after_fused << " (" << after_not_good
                << " not good)");
  CHECK(stuck >= 10);
  CHECK(stuck_fused == 0);
  CHECK(stuck_outside == 0);
  // Not before stuck_after_s of the frozen value.
  CHECK(first_stuck_h >= frozen_from_h + 600.0 / 3600.0 - 0.05);
  REQUIRE(after >= 10);
  CHECK(after_fused >= after * 9 / 10);
  const auto started = log.find("point zone_temp: STUCK");
  CHECK(started != std::string::npos);
  CHECK(started == log.rfind("point zone_temp: STUCK"));
  CHECK_THAT(log, Catch::Contains("point zone_temp: no longer stuck"));
}
