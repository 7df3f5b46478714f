// Record and replay end to end: hvac-twind records every cycle of the heat pump it estimates
// (runtime.recording_budget_mib), hvac-twin-replay runs the daemon's pipeline over the recording,
// and the replay's values equal what the daemon published over DDS, cycle by cycle, to 1e-9:
// the virtual sensors with their sigma, every point's innovation and test ratio, and the leak
// diagnostic. Only lateness may differ (a replay has no deadline).
#include <catch2/catch.hpp>
#include <map>
#include <string>
#include <tuple>

#include "io/dds/types.hpp"
#include "tests/integration/process.hpp"
#include "tests/integration/replay_csv.hpp"
#include "tests/integration/stack.hpp"

using namespace hvac_twin::test;
using namespace std::chrono_literals;

namespace {

constexpr double kSame = 1e-9;

// Runs hvac-twin-replay; its exit status.
int run_replay(const Stack& stack, const std::vector<std::string>& args) {
  Process replay(HVAC_TWIN_REPLAY_EXE, args, stack.path("replay.out"), stack.path("replay.err"));
  const auto rc = replay.wait(120s);
  return rc.value_or(-1);
}

}  // namespace

TEST_CASE("a replay of the daemon's recording reproduces what it published",
          "[integration][replay]") {
  StackOptions o = heat_pump_stack_options(86);
  o.time_scale = 20.0;  // 0.25 s wall per cycle
  o.deadline_s = 0.2;
  const auto customize = o.customize;
  o.customize = [customize](nlohmann::json& c) {
    customize(c);
    c["runtime"]["recording_budget_mib"] = 4;
  };
  Stack stack("record-replay", o);
  const auto rc = stack.run_for(40.0 * o.time_scale / 3600.0,
                                {"--topics", "unit_estimate,observation,leak_diagnostic"});
  INFO("daemon stderr:\n" << stack.daemon().err());
  REQUIRE(rc == 0);

  const std::string csv = stack.path("replay.csv");
  const int replay_rc = run_replay(
      stack, {"--config", stack.path("config.json"), "--out", csv, stack.path("state/recordings")});
  INFO("replay stderr:\n" << stack.path("replay.err"));
  REQUIRE(replay_rc == 0);
  const ReplayCsv table(csv);
  REQUIRE(table.rows.size() > 20);  // 159 in the release build; fewer, slower, under ASan
  CHECK(table.duplicate.empty());
  std::map<std::uint64_t, std::size_t> row_of;
  for (std::size_t r = 0; r < table.rows.size(); ++r)
    row_of[std::stoull(table.field(r, "cycle"))] = r;

  std::size_t estimates = 0, observations = 0, leaks = 0, compared = 0, differ = 0;
  std::string first_difference;
  auto same = [&](double published, double replayed, const std::string& what) {
    ++compared;
    if (close(published, replayed, kSame)) return;
    if (differ++ == 0)
      first_difference = what + ": published " + std::to_string(published) + ", replayed " +
                         std::to_string(replayed);
  };
  for (const auto& s : stack.samples()) {
    const auto it = row_of.find(s["cycle"].get<std::uint64_t>());
    if (it == row_of.end()) continue;
    const std::size_t row = it->second;
    const std::string at = "cycle " + std::to_string(it->first) + " ";
    if (s["topic"] == "unit_estimate") {
      ++estimates;
      const auto no_lateness = ~hvac_twin::dds::kFlagDeadlineOverrun;
      CHECK((s["flags"].get<std::uint32_t>() & no_lateness) ==
            (std::stoul(table.field(row, "flags")) & no_lateness));
      CHECK(s["fused_points"].get<std::uint64_t>() ==
            std::stoull(table.field(row, "fused_points")));
      for (const auto& e : s["estimates"]) {
        const std::string name = e["name"];
        same(e["value"], table.number(row, name), at + name);
        same(e["sigma"], table.number(row, name + "_sigma"), at + name + " sigma");
      }
    } else if (s["topic"] == "observation" && s["innovation_variance"].get<double>() > 0.0) {
      ++observations;
      const std::string p = s["point"];
      same(s["predicted"], table.number(row, p + "_predicted"), at + p + " predicted");
      same(s["innovation"], table.number(row, p + "_innovation"), at + p + " innovation");
      same(s["test_ratio"], table.number(row, p + "_test_ratio"), at + p + " test ratio");
      CHECK(s["fused"].get<bool>() == (table.field(row, p + "_fused") == "1"));
    } else if (s["topic"] == "leak_diagnostic") {
      ++leaks;
      same(s["charge"], table.number(row, "leak_diag_charge"), at + "charge");
      same(s["charge_sigma"], table.number(row, "leak_diag_charge_sigma"), at + "charge sigma");
      same(s["leak_rate"], table.number(row, "leak_diag_leak_rate"), at + "leak rate");
      same(s["rate_cusum"], table.number(row, "leak_diag_rate_cusum"), at + "rate CUSUM");
      same(s["charge_cusum"], table.number(row, "leak_diag_charge_cusum"), at + "charge CUSUM");
      CHECK(s["state"].get<std::string>() == table.field(row, "leak_diag_state"));
    }
  }
  INFO(estimates << " unit_estimate, " << observations << " observation and " << leaks
                 << " leak_diagnostic samples matched to " << table.rows.size()
                 << " replayed cycles; " << compared << " values compared, " << differ
                 << " differ; the first: " << first_difference);
  CHECK(estimates >= table.rows.size() * 8 / 10);
  CHECK(leaks >= table.rows.size() * 8 / 10);
  CHECK(observations > estimates);
  CHECK(differ == 0);
}
