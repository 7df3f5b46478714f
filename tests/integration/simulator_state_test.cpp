// The plant simulator's saved state (hvac-twin-sim --state, which the demo uses so that a
// restarted demo continues the same plant its restarted daemon resumes from a checkpoint): a
// simulation saved and restored goes on as the uninterrupted one, a restart without it does
// not, and a file it did not write is refused with its line and what was expected, changing
// nothing.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "config/load.hpp"
#include "plant_models/catalog.hpp"
#include "tests/integration/process.hpp"
#include "tests/simulator/simulation.hpp"
#include "tests/support/scratch_dir.hpp"

using namespace hvac_twin;
using namespace std::chrono_literals;

namespace {

config::UnitConfig unit_of(const char* file) {
  const auto loaded = config::load_config_file(
      std::string(HVAC_TWIN_SOURCE_DIR) + "/config/" + file, plant::model_schemas());
  REQUIRE(loaded.errors.empty());
  return loaded.config->units.front();
}

// The largest difference between two states, each in units of max(1, |value|).
double difference(std::span<const double> a, std::span<const double> b) {
  double worst = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i)
    worst = std::max(worst, std::abs(a[i] - b[i]) / std::max(1.0, std::abs(a[i])));
  return worst;
}

void run(sim::Simulation& s, int steps) {
  for (int k = 0; k < steps; ++k)
    REQUIRE(s.step());
}

}  // namespace

TEST_CASE("a saved and restored simulation goes on as the uninterrupted one",
          "[simulator][state]") {
  // The zone: saved 10 min before the end of the first 3-hour block and run on into the next,
  // whose gains are the scenario's next random draw (20 s steps). The heat pump (whose truth
  // simulates 3 h in some 20 s): saved after 10 min of its morning pull-down and run on for 10
  // more, with the thermostat and valve loops at work (5 s steps, the demo's: at 20 s the valve
  // loop hunts, and a difference of 1e-13 grew threefold a step).
  const auto [file, step_s, before, after] = GENERATE(
      std::tuple{"demo.json", 20.0, 510, 60}, std::tuple{"demo-heat-pump.json", 5.0, 120, 120});
  INFO(file);
  const config::UnitConfig unit = unit_of(file);
  sim::SimOptions o;
  o.seed = 3;
  o.step_s = step_s;
  sim::Simulation whole(unit, o);
  run(whole, before);
  std::stringstream saved;
  whole.save(saved);
  const double saved_at = whole.time_s();
  run(whole, after);

  sim::Simulation resumed(unit, o), restarted(unit, o);
  resumed.restore(saved);
  CHECK(resumed.time_s() == saved_at);
  std::stringstream again;  // all it read, as it was written
  resumed.save(again);
  CHECK(again.str() == saved.str());
  run(resumed, after);
  run(restarted, after);  // what a restart without the state serves then
  const double continued = difference(whole.state(), resumed.state());
  const double started_over = difference(whole.state(), restarted.state());
  INFO("resumed " << continued << ", started over " << started_over);
  CHECK(resumed.time_s() == whole.time_s());
  // To round-off (the model's warm starts are not saved), against a plant started over from its
  // morning.
  CHECK(continued < 1e-8);
  CHECK(started_over > 1e-2);
  CHECK(difference(whole.inputs(), resumed.inputs()) < 1e-8);
  // The sensor noise goes on with the same draws.
  std::vector<double> a(unit.points.size()), b(unit.points.size());
  whole.point_values(a);
  resumed.point_values(b);
  CHECK(difference(a, b) < 1e-8);
}

TEST_CASE("a state the simulator did not save is refused with its line, changing nothing",
          "[simulator][state]") {
  const config::UnitConfig unit = unit_of("demo-heat-pump.json");
  sim::Simulation s(unit, {});
  run(s, 3);
  std::stringstream good;
  s.save(good);
  const std::string text = good.str();
  const std::vector<double> x(s.state().begin(), s.state().end());

  std::stringstream zone_state;
  sim::Simulation zone(unit_of("demo.json"), {});
  zone.save(zone_state);

  const auto refused = [&](const std::string& bad) {
    std::istringstream in(bad);
    try {
      s.restore(in);
    } catch (const std::runtime_error& e) {
      CHECK(difference(x, s.state()) == 0.0);
      CHECK(s.time_s() == 15.0);
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  CHECK_THAT(refused(""), Catch::Contains("line 1: expected \"hvac-twin-sim state 1\", found the "
                                          "end of the file"));
  CHECK_THAT(refused(zone_state.str()),
             Catch::Contains("line 2: expected \"model heat_pump_r32 100 5\"") &&
                 Catch::Contains("found \"model zone_rc"));
  CHECK_THAT(refused(text.substr(0, text.find("\nu "))),
             Catch::Contains("line 5: expected \"u\" and 5 input values, found the end"));
  std::string nan_state = text;
  nan_state.replace(nan_state.find("\nx ") + 3, 1, "nan ");
  CHECK_THAT(refused(nan_state), Catch::Contains("line 4: expected \"x\" and 100 state values"));
  std::string scenario = text;
  scenario.erase(scenario.rfind(' '));
  CHECK_THAT(refused(scenario), Catch::Contains("line 7: expected \"scenario\""));
  // And the good one is taken after all that.
  std::istringstream in(text);
  s.restore(in);
  CHECK(s.time_s() == 15.0);
}

TEST_CASE(
    "hvac-twin-sim --state: a restarted simulator continues the plant, and a bad file is kept",
    "[simulator][state]") {
  test::ScratchDir dir("sim-state");
  const std::string config = std::string(HVAC_TWIN_SOURCE_DIR) + "/config/demo-heat-pump.json";
  const std::string state = dir / "plant.state";
  const auto start = [&](const std::string& truth) {
    // 2 wall seconds at 300x: some 120 steps of 5 s, under 20 in a sanitizer build (start-up).
    test::Process p(HVAC_TWIN_SIM_EXE,
                    {"--config", config, "--port", "0", "--time-scale", "300", "--state", state,
                     "--truth-csv", dir / truth, "--duration", "2", "--quiet"},
                    dir / "sim.out", dir / "sim.err");
    return p.wait(60s).value_or(-1);
  };
  // The model time of the first and the last row of a truth CSV.
  const auto times = [&](const std::string& truth) {
    std::ifstream in(dir / truth);
    std::string line, first;
    std::getline(in, line);  // header
    std::getline(in, first);
    std::string last = first;
    while (std::getline(in, line))
      if (!line.empty()) last = line;
    const auto t = [](const std::string& row) {
      const auto a = row.find(',') + 1;
      return std::stod(row.substr(a, row.find(',', a) - a));
    };
    return std::pair{t(first), t(last)};
  };
  REQUIRE(start("first.csv") == 0);
  const auto [t0, t1] = times("first.csv");
  CHECK(t0 == 0.0);
  CHECK(t1 >= 25.0);  // ran: at least 5 steps
  REQUIRE(start("second.csv") == 0);
  const auto [t2, t3] = times("second.csv");
  CHECK(t2 == t1);  // where the first stopped
  CHECK(t3 >= t2 + 25.0);
  CHECK_THAT(test::Process::read(dir / "sim.out"),
             Catch::Contains("continuing the plant saved in " + state));

  { std::ofstream(state, std::ios::trunc) << "hvac-twin-sim state 1\nmodel zone_rc 3 2\n"; }
  const std::string bad = test::Process::read(state);
  CHECK(start("third.csv") == 1);
  CHECK_THAT(test::Process::read(dir / "sim.err"),
             Catch::Contains("--state " + state + ": line 2: expected \"model heat_pump_r32") &&
                 Catch::Contains("remove the file to start the plant over"));
  CHECK(test::Process::read(state) == bad);  // left for a look, not overwritten
}
