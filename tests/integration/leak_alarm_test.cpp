// A leaking heat pump end to end (issue 5): the simulator loses refrigerant, the daemon's filter
// follows, its detector raises SUSPECT and then LEAK, and a Cyclone reader in this process sees
// it on hvac_twin/leak_diagnostic. The detector is compressed into minutes of model time
// (warm-up and references 10 min each, a decision per 2 min) and the leak is fast (150 g/h,
// 30 % of the charge per hour), so the whole run is under two hours of model time at 30x. The
// acceptance figures at realistic leak rates are leak_bench's (in process, days of model time).
// What would fail: a detector that alarms before the leak or never, a daemon that does not feed
// it the charge (no reference learnt), or a topic that does not carry the statistics.
#include <catch2/catch.hpp>
#include <chrono>
#include <string>

#include "io/dds/participant.hpp"
#include "io/dds/subscriber.hpp"
#include "stack.hpp"

using namespace hvac_twin;
using namespace hvac_twin::test;
using namespace std::chrono_literals;

namespace {

constexpr int kDomain = 119;
constexpr double kLeakStartS = 0.4 * 3600.0;  // after warm-up and references (20 min)

StackOptions leaking_heat_pump() {
  StackOptions o;
  o.domain_id = kDomain;
  // 30x: 167 ms of wall time per cycle. (At 60x, 83 ms, the 12-cell model with the
  // quality-dependent two-phase closure overran one cycle in five on an idle two-core machine.
  // A late cycle then skipped its update, its estimates went DEGRADED and the detector held, so
  // it never learnt its references on a busy machine. Late cycles now fuse and are judged
  // (leak_topic_test, "late cycles still fuse..."); skipped ticks are the remaining cost of load.)
  o.time_scale = 30.0;
  o.period_s = 5.0;
  o.deadline_s = 0.16;
  o.poll_period_s = 0.02;
  o.sim_step_s = 1.0;
  o.base_config = "config/demo-heat-pump.json";
  o.sim_args = {"--leak", "150@0.4"};
  o.customize = [](nlohmann::json& c) {
    auto& e = c["units"][0]["estimator"];
    e["settle_s"] = 300.0;
    e["checkpoint_every_cycles"] = 0;
    e["leak_detection"] = {{"warm_up_s", 600.0},
                           {"reference_s", 600.0},
                           {"interval_s", 120.0},
                           {"startup_s", 0.0},
                           {"charge_allowance", 0.02}};
  };
  return o;
}

}  // namespace

TEST_CASE("a leaking unit raises LEAK on the leak topic, end to end", "[integration][leak][dds]") {
  Stack stack("leak-alarm", leaking_heat_pump());
  dds::Participant participant([] {
    config::DdsConfig c;
    c.domain_id = kDomain;
    return c;  // lo, unicast to 127.0.0.1, multicast off
  }());
  dds::Subscriber reader(participant, "hvac_twin",
                         dds::TopicSet{false, false, false, true, false, false},
                         std::chrono::milliseconds(1000));
  stack.start_sim();
  stack.start_daemon();

  // Until LEAK, or 2.5 h of model time (5 min of wall time).
  std::vector<dds::Record> got;
  std::optional<dds::LeakDiagnosticRecord> first_suspect, first_leak, last_learning;
  double max_charge = 0.0;
  int with_reference = 0;
  double reference_seen = 0.0;
  const auto end = std::chrono::steady_clock::now() + 300s;
  while (!first_leak && std::chrono::steady_clock::now() < end) {
    got.clear();
    reader.wait_and_take(100ms, got);
    for (const auto& rec : got) {
      const auto& r = std::get<dds::LeakDiagnosticRecord>(rec);
      if (r.quality == dds::EstimateQuality::kNotReady) continue;
      max_charge = std::max(max_charge, r.charge);
      if (r.charge_reference == 0.0 && r.hold == dds::LeakHold::kNone) last_learning = r;
      if (r.charge_reference > 0.0) {
        ++with_reference;
        reference_seen = r.charge_reference;
      }
      if (r.state != dds::LeakState::kNormal && !first_suspect) first_suspect = r;
      if (r.state == dds::LeakState::kLeak && !first_leak) first_leak = r;
    }
  }
  INFO("daemon stderr:\n" << stack.daemon().err());  // as it is now (INFO copies at once)
  REQUIRE(first_leak.has_value());
  const dds::LeakDiagnosticRecord& l = *first_leak;
  INFO("LEAK at cycle " << l.cycle << ": charge " << l.charge << " kg against the reference "
                        << l.charge_reference << " kg; CUSUMs rate " << l.rate_cusum << " charge "
                        << l.charge_cusum << " / " << l.threshold);
  // The references were learnt while judging, before any deficit was judged.
  REQUIRE(last_learning.has_value());
  // Not before the leak: SUSPECT came after it started (model time = 5 s per cycle, give or
  // take the daemon's start after the simulator's).
  REQUIRE(first_suspect.has_value());
  CHECK(static_cast<double>(first_suspect->cycle) * 5.0 > kLeakStartS);
  CHECK(first_suspect->cycle <= l.cycle);
  // Raised by a statistic crossing the threshold, with the charge estimate down by more than
  // the allowance (10 g) from where it was. At 150 g/h the leak-rate estimate reaches many
  // sigma within minutes, so either CUSUM may be first; the published S is the larger.
  CHECK(l.cusum > l.threshold);
  CHECK(l.cusum == std::max(l.rate_cusum, l.charge_cusum));
  CHECK(l.charge < max_charge - 0.010);
  // The daemon feeds the detector the charge: it learnt reference charges at the charge's
  // level and logged them. (Published only while the unit runs in a speed band the reference
  // period ran in; this unit pulls down from 90 Hz through the whole run and may have left the
  // band before the references are complete, so the log is what is sure to carry them.)
  const std::string log = stack.daemon().err();
  const auto m = regex_find(log, R"(learnt its reference charges: .* \d+-\d* Hz (\d+\.\d+) kg)");
  REQUIRE(m.has_value());
  const double logged_reference = std::stod((*m)[1]);
  // At the charge's level, not something else fed in (0, a rate in g/h): within 20 % of the
  // nameplate. The raw charge estimate is off by up to 11 % in leak_bench's long runs, more while
  // it converges; a fresh-clone CI run logged 0.5621 kg here, and 0.5761 kg (0.5729 and 0.5744
  // by hand) since the parameters' release ramp, which slows the charge's early convergence
  // (README, "Since the parameter release ramp").
  CHECK(logged_reference == Approx(0.5).margin(0.1));
  if (with_reference > 0) CHECK(reference_seen == Approx(logged_reference).margin(1e-4));
  CHECK(l.hold == dds::LeakHold::kNone);
  CHECK(l.leak_since_ns > 0);
  // The daemon logged the transitions.
  CHECK(eventually(
      [&] {
        return stack.daemon().err().find("refrigerant leak state") != std::string::npos &&
               stack.daemon().err().find("-> LEAK") != std::string::npos;
      },
      5s));
}
