// Leak acceptance in short form (issue 5, item 4): the truth heat pump (20 cells, perturbed
// parameters, sensor noise), and the constrained EKF on the 10-cell model with the LeakDetector
// on its charge and leak-rate estimates as the daemon runs them (bench::daemon_settings()), over
// a few simulated hours. leak_bench prints the long form.
//
// Each case runs its own scenario (one to two minutes each on one core), with the detector of
// bench::short_form() (warm-up 30 min, references over the next 30 min, a decision per 15 min):
//  - normal operation, 3.5 h: warm-up, references, an hour judged, 45 min of compressor cycling,
//    30 min off and a start at full demand (the truth failed there before the scenario's
//    controllers held at rest): no SUSPECT or LEAK, the holds say why, charge and heat flows near
//    the truth;
//  - a fast leak (40 g/h, 8 % of the charge per hour) from 1 h: LEAK within 2 h.
// What would fail: a detector that never decides or alarms on noise, holds that do not hold, a
// filter whose charge does not follow the plant (the model layout's earlier noise settings: a
// 46 g loss moved its estimate by 3 g, no alarm in 22 h of a 2 g/h leak), or one that diverges.
#include <catch2/catch.hpp>

#include "tests/bench/leak_scenario.hpp"

using namespace hvac_twin;

namespace {

bench::LeakRunOptions short_run(double hours) {
  bench::LeakRunOptions o = bench::short_form(bench::daemon_settings());
  o.days = hours / 24.0;
  return o;
}

}  // namespace

TEST_CASE("normal operation raises no leak alarm and holds through cycling and off",
          "[leak][acceptance]") {
  const bench::LeakRunResult r = bench::run_leak_scenario(short_run(3.5));
  INFO("decisions " << r.decisions << ", charge moved at rest by " << 1e3 * r.stopped_drift_max
                    << " g, charge error mean " << 1e3 * r.charge_mae << " g max "
                    << 1e3 * r.charge_max << " g, Q_cond " << 100 * r.qc_mape << " %, Q_evap "
                    << 100 * r.qe_mape << " %, CUSUMs rate " << r.last.rate_cusum << " charge "
                    << r.last.charge_cusum);
  CHECK(r.filter_failures == 0);
  CHECK(r.false_suspect == 0);
  CHECK(r.false_leak == 0);
  CHECK(r.last.state == est::LeakState::kNormal);
  // It judged: two decisions learn the references (0.5-1 h), four judge the charge (1-2 h).
  CHECK(r.last.reference_learned);
  CHECK(r.charge_decisions >= 3);
  CHECK(r.decisions >= 6);
  // The holds: warm-up, cycling (from the fourth start within the hour, 40 min in), the starts
  // before it, and the compressor off (25 min of the cycling and the 30 min stop).
  const auto held = [&](est::HoldReason h) { return r.held_s[static_cast<std::size_t>(h)]; };
  CHECK(held(est::HoldReason::kWarmUp) == Approx(1800.0).margin(10.0));
  CHECK(held(est::HoldReason::kCompressorOff) >= 2700.0);  // 4 x 5 min + 30 min
  CHECK(held(est::HoldReason::kCycling) > 0.0);
  CHECK(held(est::HoldReason::kStartUp) > 0.0);
  CHECK(held(est::HoldReason::kDegraded) == 0.0);
  // The 10-cell model's charge sits 4-9 % of nameplate above the 20-cell plant's (structural,
  // measured in leak_bench): within 10 % (50 g); a filter that lost the charge is far off.
  CHECK(r.charge_max < 0.050);
  // Heat flows while running: the estimation benchmark's figures are 1-2 %; within 5 %.
  CHECK(r.qc_mape < 0.05);
  CHECK(r.qe_mape < 0.05);
}

TEST_CASE("a fast leak raises LEAK within two hours", "[leak][acceptance]") {
  bench::LeakRunOptions o = short_run(3.25);
  o.operation.enabled = false;  // the holds are the other case's; here the time goes to judging
  o.leak_g_per_h = 40.0;
  o.leak_start_s = 3600.0;
  o.stop_at_leak = true;
  const bench::LeakRunResult r = bench::run_leak_scenario(o);
  INFO("LEAK after " << r.leak_delay_s / 3600.0 << " h; charge lost: truth "
                     << 1e3 * r.truth_loss_kg << " g, estimate " << 1e3 * r.est_loss_kg
                     << " g; CUSUMs rate " << r.last.rate_cusum << " charge "
                     << r.last.charge_cusum);
  CHECK(r.filter_failures == 0);
  CHECK(r.false_suspect == 0);  // nothing before the leak started
  CHECK(r.false_leak == 0);
  REQUIRE(r.leak_raised);
  // 40 g/h crosses the 10 g allowance in 15 min; a decision every 15 min then adds
  // (deficit / 10 g - 1) = 1, 2, 3 to a CUSUM whose threshold is 5.9: LEAK at about 1 h if the
  // charge estimate followed the truth exactly. It lags: it starts to fall about 30 min after
  // the leak (the charge's random walk must first make room), and when LEAK came (after
  // 1.75 h, the CUSUM at 7.4 against 5.9) it had followed 50 of the 70 g lost. Two hours hold
  // that lag; a filter whose charge does not follow raises nothing at all (the layout's earlier
  // settings: 1 of 75 g followed, no alarm in 3 h of 25 g/h).
  CHECK(r.leak_delay_s < 2.0 * 3600.0);
  CHECK(r.suspect_delay_s <= r.leak_delay_s);
  // The estimate saw the loss: within 40 % of the truth's (the detection needs no more).
  CHECK(r.est_loss_kg == Approx(r.truth_loss_kg).epsilon(0.4));
}
