// Issue 17 items 1 and 2, end to end: six of the heat pump's seven measured points read in-range
// but absurd values for one simulated minute (hvac-twin-sim --point: both pressures 5999.9 kPa,
// the four coil walls 120 degC), then the truth again. While most measured points contradict the
// estimate the daemon must say so on every virtual sensor (quality not GOOD, flag lost_track),
// log the episode once, and recover: GOOD estimates again within a few minutes of good data, the
// pressures and the charge back at the truth within their sigma. (Before the recovery was built,
// the two pressure points stayed gated out after the fault, the discharge pressure's estimate
// 58 sigma from the truth five minutes later.)
// The fault used to be the two pressures alone, for two minutes: whether the filter then lost
// track depended on whether an absurd reading got fused before the gate shut it out (the
// covariance when the fault began), and mostly it was simply gated out, the right answer to two
// bad points of seven, so the test failed now and then on an idle machine (0 lost updates). With
// six bad points the gate rejects most points in every update of the fault; one minute (12
// updates) stays below the restart from the measured conditions (kRestartAfterLostUpdates, 15),
// which during the fault would start the filter from the absurd readings: with two minutes the
// discharge pressure was still 4 sigma off at the end.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <map>
#include <string>
#include <utility>

#include "tests/integration/stack.hpp"
#include "tests/integration/truth.hpp"

using namespace hvac_twin::test;
using namespace std::chrono_literals;

namespace {

int count_of(const std::string& text, const std::string& what) {
  int n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1))
    ++n;
  return n;
}

}  // namespace

TEST_CASE("absurd in-range readings: lost track is flagged, logged once, and recovered",
          "[integration][track]") {
  StackOptions o = heat_pump_stack_options(63);
  // The lag-free end formula on this 4-cell, constant-coefficient model (and on the simulator's
  // truth, which takes the configuration's parameters with its own closures): with the end walls
  // (stop 58) its discharge pressure is 4.4 sigma RMS off in minutes 6-9 of the start without any
  // fault (4.7 with this one), which the judgement below would count against the recovery. The
  // 12-cell model the daemon ships has them (the "no fault" case below).
  o.customize = [base = o.customize](nlohmann::json& c) {
    base(c);
    c["units"][0]["model"]["parameters"]["end_walls"] = 0;
  };
  const double bad_from_h = 2.0 / 60.0, bad_to_h = 3.0 / 60.0, end_h = 9.0 / 60.0;
  const std::string window = "@" + std::to_string(bad_from_h) + "-" + std::to_string(bad_to_h);
  o.sim_args = {"--point", "suction_pressure=5999.9" + window, "--point",
                "discharge_pressure=5999.9" + window};
  for (const char* wall : {"outdoor_coil_in_temp", "outdoor_coil_out_temp", "indoor_coil_in_temp",
                           "indoor_coil_out_temp"})
    o.sim_args.insert(o.sim_args.end(), {"--point", std::string(wall) + "=120" + window});
  Stack stack("lost-track", o);
  const auto rc = stack.run_for(end_h, {"--topics", "virtual_sensor"});
  const std::string log = stack.daemon().err();
  INFO("daemon stderr:\n" << log);
  REQUIRE(rc == 0);

  const Truth truth(stack.path("truth-1.csv"));
  int lost = 0, lost_good = 0, after = 0, after_good = 0, reset = 0;
  // Per output judged after the recovery: the number of samples and the sum of (error/sigma)^2.
  std::map<std::string, std::pair<int, double>> after_z;
  for (const auto& s : stack.samples()) {
    if (s["topic"] != "virtual_sensor") continue;
    const std::string name = s["name"];
    // (Not the suction pressure: at 4 cells its estimate is 5-6 sigma off without any fault.)
    if (name != "charge" && name != "discharge_pressure") continue;
    const auto t = s["timestamp_ns"].get<std::int64_t>();
    const double model_h = truth.model_time(t) / 3600.0;
    const auto& names = s["flag_names"];
    const bool flagged = std::find(names.begin(), names.end(), "lost_track") != names.end();
    if (name == "charge" && std::find(names.begin(), names.end(), "numerical_reset") != names.end())
      ++reset;
    if (name == "charge" && flagged) {
      ++lost;
      if (s["quality"] == "GOOD") ++lost_good;
    }
    if (model_h > bad_to_h + 3.0 / 60.0) {  // three minutes of good data later
      if (name == "charge") {
        ++after;
        if (s["quality"] == "GOOD" && !flagged) ++after_good;
      }
      const double z =
          (s["value"].get<double>() - truth.at(t, "output:" + name)) / s["sigma"].get<double>();
      auto& [n, sum_z2] = after_z[name];
      ++n;
      sum_z2 += z * z;
    }
  }
  INFO("lost_track samples " << lost << " (GOOD " << lost_good << "); after recovery " << after
                             << " samples, GOOD " << after_good << "; numerical_reset " << reset);
  CHECK(lost >= 2);
  CHECK(lost_good == 0);
  CHECK(count_of(log, "lost track:") >= 1);
  CHECK(count_of(log, "lost track:") == count_of(log, "back on track after"));
  // The filter's own covariance reset (issue 17 item 2) is flagged on the samples and logged.
  CHECK(reset >= 1);
  CHECK(count_of(log, "the filter reset its covariance") >= 1);
  REQUIRE(after >= 10);
  CHECK(after_good >= after * 9 / 10);
  // Back at the truth within the published uncertainty (which carries the 4-cell model's
  // structural error), judged as the RMS of error/sigma over the three minutes after the
  // recovery, not on one sample: the discharge pressure's error/sigma swings by up to 2.6 from one
  // sample to the next (seen from -2.6 to 1.9 in one run), so a single sample judged against
  // 3 sigma failed once in CI (3.9 sigma) with the estimate recovered. Seen: RMS 1.14 for the
  // discharge pressure, 0.45 for the charge; before the recovery was built it stayed 58 sigma off.
  // With adaptive noise (1:9, the default since stop 47): 1.51 and 0.65; 2.32 for the pressure
  // while the noise adapter still learnt from the updates of the fault
  // (NoiseAdapterOptions::hold_updates).
  REQUIRE(after_z.size() == 2);
  for (const auto& [name, z] : after_z) {
    const double rms = std::sqrt(z.second / z.first);
    INFO(name << ": RMS of error/sigma " << rms << " over " << z.first << " samples");
    CHECK(rms < 2.0);
  }
}

// Issue 12 ("a sensor rejected by the gate for long is a reported fault, not a normal state"),
// end to end with no fault at all, on the model the daemon ships (config/demo-heat-pump.json: 12
// cells, every closure and both efficiencies estimated) against the simulator's 20-cell truth
// with its other closures: after the parameter release at parameter_hold_s every measured point
// keeps being fused, and the filter never loses track. The outdoor coil's fouling and the
// condensing coefficient start 1.7 prior sigma off (1.25 and 1.5 for 1 and 1): released at once
// (parameter_release_s 0) the first update moved them so far that the condenser-outlet wall was
// gated out for good (fused in 0 of 72 cycles, 3 runs of 3); with the ramp, 72 of 72. From the
// nominal guesses the instant release failed so too, rarely (once in CI, once in 27 runs by hand,
// the discharge pressure). (On the cut-down 4-cell stack of the test above points stayed out,
// measured before the ramp: README, "Lost track".)
TEST_CASE("no fault: the parameter release keeps every measured point in", "[integration][track]") {
  StackOptions o = heat_pump_stack_options(70);
  const double hold_s = 240.0, end_h = 12.0 / 60.0, judged_from_h = (hold_s + 120.0) / 3600.0;
  o.customize = [hold_s](nlohmann::json& c) {
    c["units"][0]["estimator"]["settle_s"] = 300.0;
    c["units"][0]["estimator"]["parameter_hold_s"] = hold_s;
    c["units"][0]["estimator"]["initial_state"] = {{"fouling", 1.25}, {"cond_htc_factor", 1.5}};
  };
  Stack stack("release", o);
  const auto rc = stack.run_for(end_h, {"--topics", "observation"});
  const std::string log = stack.daemon().err();
  INFO("daemon stderr:\n" << log);
  REQUIRE(rc == 0);

  const Truth truth(stack.path("truth-1.csv"));
  std::map<std::string, std::pair<int, int>> judged;  // point: (samples, fused)
  for (const auto& s : stack.samples()) {
    if (s["topic"] != "observation" || s["quality"] != "GOOD") continue;
    if (truth.model_time(s["timestamp_ns"].get<std::int64_t>()) / 3600.0 < judged_from_h) continue;
    auto& [samples, fused] = judged[s["point"].get<std::string>()];
    ++samples;
    fused += s["fused"] == true ? 1 : 0;
  }
  REQUIRE(judged.size() == 7);
  for (const auto& [point, counts] : judged) {
    INFO(point << ": fused " << counts.second << " of " << counts.first
               << " samples from 2 minutes after the release");
    CHECK(counts.first >= 50);
    CHECK(counts.second >= counts.first * 9 / 10);
  }
  CHECK(count_of(log, "lost track:") == 0);
}
