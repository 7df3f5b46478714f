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
