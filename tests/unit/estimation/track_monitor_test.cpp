// Lost track (issue 17 items 1 and 2): a filter whose covariance claims a certainty the data
// contradicts is recognised from its own update reports, its covariance reset is reported, and
// the episode is counted once, start to end.
#include "daemon/estimation/track_monitor.hpp"

#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "daemon/estimation/ekf.hpp"
#include "plant_models/core/ad_model.hpp"
#include "test_models.hpp"

using namespace hvac_twin;

namespace {

// Three sensors of one quantity in [0, 1] (a charge read through three temperatures, say).
struct ThreeSensors : test::RandomWalk {
  plant::ModelLayout layout() const {
    plant::ModelLayout l = test::RandomWalk::layout();
    l.states[0].min = 0.0;
    l.states[0].max = 1.0;
    l.outputs = {plant::SignalInfo{.name = "a", .unit = "1"},
                 plant::SignalInfo{.name = "b", .unit = "1"},
                 plant::SignalInfo{.name = "c", .unit = "1"}};
    return l;
  }
  template <class S>
  int outputs(std::span<const S> x, std::span<const double>, std::span<S> y) const {
    for (std::size_t i = 0; i < 3; ++i)
      y[i] = x[0];
    return plant::kModelOk;
  }
};

std::vector<est::MeasurementReport> reports(int available, int rejected) {
  std::vector<est::MeasurementReport> r(4);
  for (int i = 0; i < available; ++i) {
    r[static_cast<std::size_t>(i)].available = true;
    r[static_cast<std::size_t>(i)].rejected = i < rejected;
    r[static_cast<std::size_t>(i)].fused = i >= rejected;
  }
  return r;
}

}  // namespace

TEST_CASE("lost track: most available points gated out twice in a row, one episode", "[track]") {
  est::TrackMonitor m(2, 4);
  for (int i = 0; i < 3; ++i) {
    CHECK_FALSE(m.observe(reports(3, 1), false).lost);  // a minority rejected: on track
    CHECK_FALSE(m.observe(reports(4, 2), false).lost);  // half is not most
    CHECK_FALSE(m.observe(reports(1, 1), false).lost);  // one point alone is never judged
    CHECK_FALSE(m.observe(reports(0, 0), false).lost);
  }
  CHECK_FALSE(m.observe(reports(3, 2), false).lost);  // one contradicted update: a transient
  CHECK_FALSE(m.observe(reports(3, 0), false).lost);
  CHECK(m.episodes() == 0);

  auto s = m.observe(reports(3, 2), false);
  CHECK_FALSE(s.lost);
  s = m.observe(reports(3, 3), false);
  CHECK(s.lost);  // the second in a row
  CHECK(s.episode_started);
  CHECK(s.available == 3);
  CHECK(s.rejected == 3);
  s = m.observe(reports(3, 3), true);
  CHECK(s.lost);
  CHECK_FALSE(s.episode_started);
  CHECK(s.first_reset);
  s = m.observe(reports(3, 3), true);
  CHECK_FALSE(s.first_reset);  // once per episode
  CHECK_FALSE(s.restart_due);
  s = m.observe(reports(3, 3), false);
  CHECK(s.restart_due);  // the fourth lost update in a row
  CHECK(s.first_restart);
  CHECK(m.lost());
  for (int i = 0; i < 3; ++i)
    CHECK_FALSE(m.observe(reports(3, 3), false).restart_due);
  s = m.observe(reports(3, 3), false);
  CHECK(s.restart_due);  // the restarted filter had four updates of its own
  CHECK_FALSE(s.first_restart);

  s = m.observe(reports(3, 0), false);
  CHECK_FALSE(s.lost);
  CHECK(s.episode_ended);
  CHECK_FALSE(m.lost());
  CHECK(m.last_episode().updates == 8);
  CHECK(m.last_episode().covariance_resets == 2);
  CHECK(m.last_episode().restarts == 2);
  CHECK(m.episodes() == 1);
  CHECK_FALSE(m.observe(reports(3, 0), false).episode_ended);  // once

  m.observe(reports(2, 2), false);
  CHECK(m.observe(reports(2, 2), false).episode_started);
  CHECK(m.episodes() == 2);
}

TEST_CASE("an EKF confidently wrong at its bound: lost track, covariance reset, back on track",
          "[track][ekf]") {
  // The state of issue 17 item 1: absurd in-range readings drove the estimate to its bound with
  // a tiny variance; then the good data returns (truth 0.5) and contradicts it.
  const plant::AdModel<ThreeSensors> model{ThreeSensors{}};
  est::EkfOptions opt;
  opt.constrained = true;
  opt.max_consecutive_rejections = 5;
  est::Ekf ekf(model, std::vector<double>{1e-6}, 3, opt);
  ekf.reset(std::vector<double>{0.5}, std::vector<double>{0.2});  // the initial covariance
  const std::vector<double> x_wrong{0.9999}, P_wrong{1e-8};
  REQUIRE(ekf.restore(x_wrong, P_wrong, est::EstimatorCounters{}));

  est::TrackMonitor monitor(2, 15);
  std::vector<est::Measurement> z(3);
  std::vector<est::MeasurementReport> rep(3);
  for (std::size_t i = 0; i < 3; ++i)
    z[i] = {.output = i,
            .value = 0.5 + 0.01 * static_cast<double>(i) - 0.01,
            .variance = 1e-4,
            .available = true};
  int lost = 0, started = 0, resets = 0, ended = 0, update_of_reset = 0;
  for (int k = 1; k <= 10; ++k) {
    REQUIRE(ekf.predict({}, 1.0) == est::StepStatus::kOk);
    const auto before = ekf.counters().covariance_resets;
    REQUIRE(ekf.update(z, {}, rep) == est::StepStatus::kOk);
    const bool reset = ekf.counters().covariance_resets != before;
    const auto s = monitor.observe(rep, reset);
    lost += s.lost ? 1 : 0;
    started += s.episode_started ? 1 : 0;
    ended += s.episode_ended ? 1 : 0;
    if (s.first_reset) {
      ++resets;
      update_of_reset = k;
    }
  }
  // Contradicted in the four updates before the filter's own reset at the fifth, which
  // re-tested and fused the same measurements; lost from the second: the episode ends at the
  // reset, and the estimate is back at the data.
  CHECK(lost == 3);
  CHECK(started == 1);
  CHECK(resets == 1);
  CHECK(update_of_reset == 5);
  CHECK(ended == 1);
  CHECK(monitor.last_episode().updates == 3);
  CHECK(monitor.last_episode().covariance_resets == 1);
  CHECK(ekf.state()(0) == Approx(0.5).margin(0.01));
  CHECK_FALSE(monitor.lost());
}

TEST_CASE("a transmitter gone wrong: held out of the reset, re-admission tests back off",
          "[track][ekf]") {
  // Confidently wrong at the bound, as above; two sensors right (0.5), the third wrong (0.95, in
  // range). At the filter's reset all three are faulty and held out: re-tested one by one, the
  // first gets in against the initial covariance, and the wrong one fails against its posterior.
  // Being plausible against the initial covariance, the wrong one is re-admitted 10 updates
  // later by a reset that tests every point against it (the recovery for a right sensor the
  // estimate drifted away from): it gets in for that update, but at a Huber weight
  // (EkfOptions::robust_threshold), which moves the estimate too little for the right ones to be
  // rejected after it; the wrong one is rejected again. The next test waits twice as long, and
  // so on: a wrong sensor costs one update at a reduced weight, ever more rarely. (At full
  // weight it dragged the estimate so far that the right ones were rejected, and 5 updates
  // later the filter was lost and reset again: resets at 5, 15, 20, 35, 40, 75, 80.)
  const plant::AdModel<ThreeSensors> model{ThreeSensors{}};
  est::EkfOptions opt;
  opt.max_consecutive_rejections = 5;
  est::Ekf ekf(model, std::vector<double>{1e-6}, 3, opt);
  ekf.reset(std::vector<double>{0.5}, std::vector<double>{0.2});
  const std::vector<double> x_wrong{0.9999}, P_wrong{1e-8};
  REQUIRE(ekf.restore(x_wrong, P_wrong, est::EstimatorCounters{}));
  std::vector<est::Measurement> z(3);
  for (std::size_t i = 0; i < 3; ++i)
    z[i] = {.output = i, .value = i == 2 ? 0.95 : 0.5, .variance = 1e-4, .available = true};
  std::vector<est::MeasurementReport> rep(3);
  std::vector<int> wrong_in, resets_at;
  for (int k = 1; k <= 84; ++k) {
    const auto resets = ekf.counters().covariance_resets;
    REQUIRE(ekf.predict({}, 1.0) == est::StepStatus::kOk);
    REQUIRE(ekf.update(z, {}, rep) == est::StepStatus::kOk);
    if (rep[2].fused) wrong_in.push_back(k);
    if (ekf.counters().covariance_resets != resets) resets_at.push_back(k);
    if (k == 5) {
      CHECK(rep[0].fused);
      CHECK(rep[1].fused);
      CHECK(rep[2].rejected);
      CHECK(ekf.state()(0) == Approx(0.5).margin(0.01));
    }
  }
  CHECK(resets_at == std::vector<int>{5, 15, 35, 75});
  CHECK(wrong_in == std::vector<int>{15, 35, 75});  // 10, 20, 40 updates after the last reset
  CHECK(ekf.state()(0) == Approx(0.5).margin(0.01));
  z[2].value = 0.5;  // repaired: back in at once, by the gate
  REQUIRE(ekf.predict({}, 1.0) == est::StepStatus::kOk);
  REQUIRE(ekf.update(z, {}, rep) == est::StepStatus::kOk);
  CHECK(rep[2].fused);
}
