// The leak detector: its CUSUM design against published run lengths and against simulation,
// detection of a shift, holds while the model cannot judge, and hysteresis.
#include "daemon/estimation/leak_detector.hpp"

#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

using namespace hvac_twin::est;

namespace {

// A detector that decides every second (interval 1 s) with no warm-up or start-up hold.
LeakDetectorOptions every_second(double arl0_decisions) {
  LeakDetectorOptions o;
  o.interval_s = 1.0;
  o.warm_up_s = 0.0;
  o.startup_s = 0.0;
  o.false_alarm_interval_days = arl0_decisions / 86400.0;
  return o;
}

// Decisions until LEAK with z ~ N(mean, 1) (capped).
long run_length(const LeakDetectorOptions& o, double mean, std::mt19937_64& rng, long cap) {
  LeakDetector d(o);
  std::normal_distribution<double> g(mean, 1.0);
  d.step(0.0, 0.0, 1.0, 50.0, false);
  for (long k = 1; k <= cap; ++k)
    if (d.step(static_cast<double>(k), g(rng), 1.0, 50.0, false).state == LeakState::kLeak)
      return k;
  return cap;
}

}  // namespace

TEST_CASE("Siegmund's run length matches the published CUSUM table", "[leak]") {
  // Montgomery, Introduction to Statistical Quality Control, Table 9.3 (k = 0.5).
  CHECK(LeakDetector::arl0(0.5, 4.0) == Approx(336.0).epsilon(0.02));
  CHECK(LeakDetector::arl0(0.5, 5.0) == Approx(930.0).epsilon(0.02));
}

TEST_CASE("the designed false-alarm rate holds in simulation", "[leak]") {
  const auto o = every_second(1000.0);  // design: one false alarm per 1000 decisions
  std::mt19937_64 rng(99);
  double sum = 0.0;
  const int runs = 300;
  for (int i = 0; i < runs; ++i)
    sum += static_cast<double>(run_length(o, 0.0, rng, 100000));
  const double mean = sum / runs;
  INFO("mean in-control run length " << mean << " decisions (designed 1000)");
  // Siegmund's approximation is a few per cent off at this threshold, and 300 runs have a
  // sampling error of ~6 %: within 20 %.
  CHECK(mean > 800.0);
  CHECK(mean < 1200.0);
}

TEST_CASE("a leak of the design size is found within a few decisions", "[leak]") {
  const auto o = every_second(17520.0);  // a year of half-hour decisions
  std::mt19937_64 rng(5);
  double sum = 0.0;
  for (int i = 0; i < 200; ++i)
    sum += static_cast<double>(run_length(o, 2.0, rng, 1000));
  const double mean = sum / 200;
  INFO("mean detection delay " << mean << " decisions at a 2-sigma shift");
  CHECK(mean < 12.0);
  CHECK(mean > 3.0);
}

TEST_CASE("the detector holds while the model cannot judge, and says why", "[leak]") {
  LeakDetectorOptions o;
  o.interval_s = 60.0;
  o.warm_up_s = 600.0;
  o.startup_s = 300.0;
  LeakDetector d(o);
  double t = 0.0;
  const auto step = [&](double leak, double hz, bool degraded = false) {
    t += 10.0;
    return d.step(t, leak, 1.0, hz, degraded);
  };
  CHECK(d.step(t, 5.0, 1.0, 50.0, false).hold == HoldReason::kWarmUp);
  for (int i = 0; i < 59; ++i)
    step(5.0, 50.0);
  CHECK(d.report().hold == HoldReason::kWarmUp);
  CHECK(d.report().cusum == 0.0);
  step(5.0, 50.0);
  CHECK(d.report().hold == HoldReason::kNone);
  for (int i = 0; i < 6; ++i)
    step(5.0, 50.0);
  CHECK(d.report().decisions == 1);
  const double s = d.report().cusum;
  CHECK(s > 0.0);
  // Compressor off: held, nothing accumulates.
  for (int i = 0; i < 20; ++i)
    CHECK(step(5.0, 0.0).hold == HoldReason::kCompressorOff);
  CHECK(d.report().cusum == s);
  // Restart: start-up hold for 300 s.
  CHECK(step(5.0, 50.0).hold == HoldReason::kStartUp);
  for (int i = 0; i < 29; ++i)
    step(5.0, 50.0);
  CHECK(step(5.0, 50.0).hold == HoldReason::kNone);
  // Degraded estimates.
  CHECK(step(5.0, 50.0, true).hold == HoldReason::kDegraded);
  // Cycling: four starts within the hour.
  for (int c = 0; c < 3; ++c) {
    step(5.0, 0.0);
    step(5.0, 50.0);
  }
  CHECK(step(5.0, 50.0).hold == HoldReason::kCycling);
  CHECK(to_string(HoldReason::kCycling) == "compressor cycling");
}

TEST_CASE("alarm states have hysteresis", "[leak]") {
  const auto o = every_second(17520.0);
  LeakDetector d(o);
  const double h = d.threshold();
  double t = 0.0;
  d.step(t, 0.0, 1.0, 50.0, false);
  // A steady 3-sigma leak: SUSPECT, then LEAK.
  bool saw_suspect = false;
  while (d.report().state != LeakState::kLeak) {
    d.step(++t, 3.0, 1.0, 50.0, false);
    saw_suspect = saw_suspect || d.report().state == LeakState::kSuspect;
  }
  CHECK(saw_suspect);
  CHECK(d.report().first_suspect_s < d.report().first_leak_s);
  // The leak stops (z = 0): S falls by k per decision; LEAK stays while S >= h/4 (not merely
  // below h, where it was raised), then NORMAL.
  int leak_decisions = 0;
  for (;;) {
    d.step(++t, 0.0, 1.0, 50.0, false);
    if (d.report().cusum < 0.25 * h) break;
    CHECK(d.report().state == LeakState::kLeak);
    ++leak_decisions;
  }
  CHECK(leak_decisions > 0);
  CHECK(d.report().state == LeakState::kNormal);
}

TEST_CASE("a restored detector continues exactly where the saved one was", "[leak]") {
  LeakDetectorOptions o = every_second(17520.0);
  o.warm_up_s = 30.0;
  o.startup_s = 5.0;
  LeakDetector original(o);
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g(1.2, 1.0);  // a small leak: the CUSUM climbs slowly
  double t = 0.0;
  // Mid-way through: warm-up over, a compressor stop and start in the history, a partial
  // interval accumulated, CUSUM above zero.
  for (; t < 80.0; t += 0.5)
    original.step(t, g(rng), 1.0, (t > 40.0 && t < 45.0) ? 0.0 : 50.0, false);
  REQUIRE(original.report().decisions > 10);
  REQUIRE(original.report().cusum > 0.0);

  std::array<double, LeakDetector::kStateSize> saved{};
  original.save_state(saved);
  LeakDetector restored(o);
  REQUIRE(restored.restore_state(saved));
  for (; t < 400.0; t += 0.5) {
    const double z = g(rng);
    const double hz = (t > 200.0 && t < 203.0) ? 0.0 : 50.0;
    const LeakReport& a = original.step(t, z, 1.0, hz, false);
    const LeakReport& b = restored.step(t, z, 1.0, hz, false);
    REQUIRE(a.state == b.state);
    REQUIRE(a.hold == b.hold);
    REQUIRE(a.cusum == b.cusum);
    REQUIRE(a.decisions == b.decisions);
  }
  CHECK(original.report().first_leak_s == restored.report().first_leak_s);

  // A fresh detector is different: the comparison above can fail.
  LeakDetector fresh(o);
  CHECK(fresh.step(t, 0.0, 1.0, 50.0, false).hold == HoldReason::kWarmUp);

  // Nonsense is refused and changes nothing.
  auto bad = saved;
  bad[0] = 7.0;  // no such alarm state
  CHECK_FALSE(fresh.restore_state(bad));
  bad = saved;
  bad[2] = std::nan("");
  CHECK_FALSE(fresh.restore_state(bad));
  bad = saved;
  bad[19] = 9.0;  // more starts than the ring holds
  CHECK_FALSE(fresh.restore_state(bad));
  CHECK_FALSE(fresh.restore_state(std::span<const double>(saved.data(), saved.size() - 1)));
  CHECK(fresh.report().decisions == 0);
}

TEST_CASE("the sigma floor keeps a collapsed sigma from reading as a leak", "[leak]") {
  // A constrained filter's leak rate resting on its bound reports a tiny sigma; an excursion of
  // 0.05 g/h at sigma 0.02 is 2.5 sigma without the floor, 0.5 with a 0.1 floor.
  auto o = every_second(17520.0);
  LeakDetector plain(o);
  o.sigma_floor = 0.1;
  LeakDetector floored(o);
  for (int k = 0; k <= 200; ++k) {
    plain.step(k, 0.05, 0.02, 50.0, false);
    floored.step(k, 0.05, 0.02, 50.0, false);
  }
  CHECK(plain.report().state == LeakState::kLeak);
  CHECK(floored.report().statistic == Approx(0.5));
  CHECK(floored.report().cusum == 0.0);
  CHECK(floored.report().state == LeakState::kNormal);
  // Above the floor the filter's sigma is used as before.
  LeakDetector same(o);
  same.step(0.0, 0.3, 0.2, 50.0, false);
  CHECK(same.step(1.0, 0.3, 0.2, 50.0, false).statistic == Approx(1.5));
}

TEST_CASE("the charge deficit: a reference first, then only a deficit beyond the allowance",
          "[leak]") {
  auto o = every_second(17520.0);
  o.charge_allowance = 0.010;  // kg
  o.reference_s = 10.0;        // ten decisions
  LeakDetector d(o);
  // Two statistics share the designed false-alarm rate: each gets twice the run length.
  CHECK(d.threshold() > LeakDetector(every_second(17520.0)).threshold());
  CHECK(LeakDetector::arl0(1.0, d.threshold()) == Approx(2.0 * 17520.0).epsilon(1e-6));
  double t = 0.0;
  const auto step = [&](double charge) {
    return d.step(t++, 0.0, 0.4, charge, 0.001, 50.0, false);
  };
  step(0.54);
  // The reference: the mean over the first ten decisions (0.53 and 0.55 alternating).
  for (int k = 0; k < 10; ++k) {
    CHECK_FALSE(d.report().reference_learned);
    step(k % 2 ? 0.55 : 0.53);
  }
  CHECK(d.report().reference_learned);
  // A wander inside the allowance (9 g below the reference) never accumulates.
  for (int k = 0; k < 500; ++k)
    step(0.531);
  CHECK(d.report().charge_reference == Approx(0.54));
  CHECK(d.report().charge_statistic == Approx(0.9).epsilon(0.01));
  CHECK(d.report().charge_cusum == 0.0);
  CHECK(d.report().state == LeakState::kNormal);
  // A growing deficit (a leak of 1 g per decision): SUSPECT, then LEAK, from the charge alone
  // while the leak-rate estimate says nothing.
  double c = 0.54;
  int decisions = 0;
  while (d.report().state != LeakState::kLeak && decisions < 100) {
    c -= 0.001;
    step(c);
    ++decisions;
  }
  CHECK(d.report().state == LeakState::kLeak);
  CHECK(d.report().rate_cusum == 0.0);
  CHECK(d.report().cusum == d.report().charge_cusum);
  // The deficit passes the allowance after 10 decisions; (deficit/allowance - 1) adds
  // 0.1, 0.2, ... so h ~ 6 takes about 11 more.
  CHECK(decisions > 15);
  CHECK(decisions < 30);
  CHECK(d.report().first_suspect_s < d.report().first_leak_s);
}

TEST_CASE("the charge noise scales the deficit beyond the allowance", "[leak]") {
  // The same growing deficit (1 g per decision) counted in units of the allowance (10 g, the
  // design with the noise unset) and of a measured in-control noise of 2.5 g.
  const auto decisions_to_leak = [](double noise) {
    auto o = every_second(17520.0);
    o.charge_allowance = 0.010;
    o.charge_noise = noise;
    o.reference_s = 10.0;
    LeakDetector d(o);
    double t = 0.0;
    for (int k = 0; k < 11; ++k)  // the reference: 0.54
      d.step(t++, 0.0, 0.4, 0.54, 0.001, 50.0, false);
    REQUIRE(d.report().reference_learned);
    for (int k = 0; k < 500; ++k)  // a wander within the allowance (9 g): never accumulates
      d.step(t++, 0.0, 0.4, 0.54 - 0.009 * (k % 2), 0.001, 50.0, false);
    CHECK(d.report().charge_cusum == 0.0);
    CHECK(d.report().state == LeakState::kNormal);
    double c = 0.54;
    int n = 0;
    while (d.report().state != LeakState::kLeak && n < 100) {
      c -= 0.001;
      d.step(t++, 0.0, 0.4, c, 0.001, 50.0, false);
      ++n;
    }
    CHECK(d.report().threshold == Approx(LeakDetector(every_second(17520.0 * 2.0)).threshold()));
    return n;
  };
  const int by_allowance = decisions_to_leak(0.0);
  const int by_noise = decisions_to_leak(0.0025);
  CHECK(by_allowance == decisions_to_leak(0.010));  // noise = allowance: the same design
  // Beyond the allowance after 10 decisions; then (deficit - 10 g) / 2.5 g = 0.4, 0.8 on a
  // threshold designed for k = 4 (h_c 0.58) gives LEAK at the 12th, against the 19th when the
  // allowance is the scale ((deficit - 10 g) / 10 g = 0.1, 0.2, ... on h = 4.4).
  CHECK(by_noise == 12);
  CHECK(by_allowance == 19);
}

TEST_CASE("the charge is judged against the reference of its compressor-speed band", "[leak]") {
  // The model's charge offset depends on the operating point: here the estimate reads 0.54 at
  // 25 Hz and 0.52 at 85 Hz without any leak.
  auto o = every_second(17520.0);
  o.charge_allowance = 0.010;
  o.reference_s = 20.0;
  LeakDetector d(o);
  double t = 0.0;
  d.step(t++, 0.0, 0.4, 0.54, 0.001, 25.0, false);
  for (int k = 0; k < 20; ++k) {              // the reference period runs at 25 Hz only
    CHECK(d.reference_charge(25.0) == -1.0);  // not before the period is over
    d.step(t++, 0.0, 0.4, 0.54, 0.001, 25.0, false);
  }
  REQUIRE(d.report().reference_learned);
  // At 85 Hz the band has no reference: not judged on the charge, however low it reads.
  for (int k = 0; k < 200; ++k)
    d.step(t++, 0.0, 0.4, 0.52, 0.001, 85.0, false);
  CHECK(d.report().charge_reference == -1.0);
  CHECK(d.report().interval_charge == Approx(0.52));  // the last decision's means
  CHECK(d.report().interval_charge_sigma == Approx(0.001));
  CHECK(d.report().interval_speed_hz == Approx(85.0));
  CHECK(d.reference_charge(85.0) == -1.0);
  CHECK(d.reference_charge(25.0) == Approx(0.54));
  CHECK(d.reference_charge(39.9) == Approx(0.54));  // the 20-40 Hz band
  CHECK(d.report().charge_cusum == 0.0);
  CHECK(d.report().state == LeakState::kNormal);
  // Back at 25 Hz with 30 g missing: judged against 0.54, and raised.
  for (int k = 0; k < 20; ++k)
    d.step(t++, 0.0, 0.4, 0.51, 0.001, 25.0, false);
  CHECK(d.report().charge_reference == Approx(0.54));
  CHECK(d.report().state == LeakState::kLeak);
}

TEST_CASE("without the charge, or with the allowance at 0, the detector is the rate CUSUM",
          "[leak]") {
  auto o = every_second(17520.0);
  o.reference_s = 5.0;
  LeakDetector rate_only(o);  // allowance 0: the charge is ignored
  o.charge_allowance = 0.010;
  LeakDetector no_charge(o);  // allowance set, but the five-argument step
  std::mt19937_64 rng(3);
  std::normal_distribution<double> g(0.8, 1.0);
  for (int k = 0; k < 300; ++k) {
    const double z = g(rng);
    const double charge = 0.5 - 0.001 * k;  // a deficit that would alarm if it were used
    const auto& a = rate_only.step(k, z, 1.0, charge, 0.001, 50.0, false);
    const auto& b = no_charge.step(k, z, 1.0, 50.0, false);
    REQUIRE(a.cusum == a.rate_cusum);
    REQUIRE(a.charge_cusum == 0.0);
    REQUIRE(b.charge_cusum == 0.0);
    REQUIRE(b.charge_reference < 0.0);
  }
}

TEST_CASE("a restored detector continues the charge deficit exactly", "[leak]") {
  auto o = every_second(17520.0);
  o.charge_allowance = 0.010;
  o.reference_s = 20.0;
  o.interval_s = 4.0;  // several steps per decision: a partial interval is saved
  LeakDetector original(o);
  std::mt19937_64 rng(21);
  std::normal_distribution<double> g(0.0, 0.003);
  double t = 0.0, c = 0.54;
  for (; t < 150.0; t += 1.0) {
    c -= 0.0002;
    original.step(t, 0.1, 0.4, c + g(rng), 0.001, 50.0, false);
  }
  REQUIRE(original.report().charge_reference > 0.0);
  REQUIRE(original.report().charge_cusum > 0.0);
  std::array<double, LeakDetector::kStateSize> saved{};
  original.save_state(saved);
  LeakDetector restored(o);
  REQUIRE(restored.restore_state(saved));
  for (; t < 400.0; t += 1.0) {
    c -= 0.0002;
    const double charge = c + g(rng);
    const LeakReport& a = original.step(t, 0.1, 0.4, charge, 0.001, 50.0, false);
    const LeakReport& b = restored.step(t, 0.1, 0.4, charge, 0.001, 50.0, false);
    REQUIRE(a.state == b.state);
    REQUIRE(a.cusum == b.cusum);
    REQUIRE(a.charge_cusum == b.charge_cusum);
    REQUIRE(a.charge_reference == b.charge_reference);
    REQUIRE(a.decisions == b.decisions);
  }
  CHECK(original.report().state == LeakState::kLeak);
  CHECK(original.report().first_leak_s == restored.report().first_leak_s);
  // A saved state whose CUSUM is not the larger of its two parts is refused.
  auto bad = saved;
  bad[23] = bad[2] + 1.0;
  LeakDetector fresh(o);
  CHECK_FALSE(fresh.restore_state(bad));
  bad = saved;
  bad[26] = -0.5;  // a reference is -1 (none) or a charge
  CHECK_FALSE(fresh.restore_state(bad));
  CHECK(fresh.report().decisions == 0);
}

TEST_CASE("only a leak rate beyond the allowance accumulates", "[leak]") {
  // leak_bench's 7 days of normal operation: the estimate sat at about 3 g/h on a published
  // sigma of about 3.3 g/h, z about 1 = k, so S_rate drifted. With the allowance at that level
  // an in-control interval adds nothing, and a leak beyond it is found as before.
  auto o = every_second(17520.0);
  const auto s_rate = [&](double allowance, double leak, int decisions) {
    o.rate_allowance = allowance;
    LeakDetector d(o);
    d.step(0.0, leak, 3.3, 50.0, false);
    for (int k = 1; k <= decisions; ++k)
      d.step(static_cast<double>(k), leak, 3.3, 50.0, false);
    return d.report();
  };
  // In control, 3.6 g/h: z 1.09, 0.09 above k per decision without the allowance.
  CHECK(s_rate(0.0, 3.6, 100).rate_cusum == Approx(100 * (3.6 / 3.3 - 1.0)).epsilon(1e-9));
  CHECK(s_rate(0.0, 3.6, 100).state != LeakState::kNormal);
  CHECK(s_rate(3.5, 3.6, 100).rate_cusum == 0.0);
  CHECK(s_rate(3.5, 3.6, 100).state == LeakState::kNormal);
  CHECK(s_rate(3.5, 3.6, 100).statistic == Approx(0.1 / 3.3).epsilon(1e-9));
  // A leak of 2 sigma beyond the allowance: z 2, k 1, LEAK once S_rate passes h.
  const LeakReport leak = s_rate(3.5, 3.5 + 2.0 * 3.3, 8);
  CHECK(leak.rate_cusum == Approx(8.0).epsilon(1e-9));
  CHECK(leak.state == LeakState::kLeak);
}
