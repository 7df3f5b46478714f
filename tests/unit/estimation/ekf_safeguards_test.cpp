// Reliability safeguards of the EKF: gate, faulty points, skipped input, health check, clamps.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <vector>

#include "daemon/estimation/ekf.hpp"
#include "plant_models/core/ad_model.hpp"
#include "test_models.hpp"

using namespace hvac_twin;

namespace {

struct Failing : test::RandomWalk {
  template <class S>
  int rhs(std::span<const S>, std::span<const double>, std::span<S>) const {
    return plant::kModelFatal;
  }
};

struct Bounded : test::RandomWalk {
  plant::ModelLayout layout() const {
    auto l = test::RandomWalk::layout();
    l.states[0].min = 0.0;
    l.states[0].max = 1.0;
    return l;
  }
};

// A model defined on part of its state's box: like the heat pump, whose enthalpy bound once let an
// update leave the property table at the condenser's pressure. Its right-hand side fails above 5.
struct PartDomain : test::RandomWalk {
  plant::ModelLayout layout() const {
    auto l = test::RandomWalk::layout();
    l.states[0].min = 0.0;
    l.states[0].max = 10.0;
    return l;
  }
  template <class S>
  int rhs(std::span<const S> x, std::span<const double>, std::span<S> f) const {
    if (x[0] > 5.0) return plant::kModelRecoverable;
    f[0] = S(0.0);
    return plant::kModelOk;
  }
};

est::Measurement meas(double value, double variance = 0.01) {
  return {.output = 0, .value = value, .variance = variance, .available = true};
}

}  // namespace

TEST_CASE("the innovation gate rejects a glitch and counts it", "[ekf][gate]") {
  const plant::AdModel<test::RandomWalk> model{test::RandomWalk{}};
  est::EkfOptions opt;
  opt.max_consecutive_rejections = 3;
  est::Ekf ekf(model, std::vector<double>{0.01}, 1, opt);
  ekf.reset(std::vector<double>{5.0}, std::vector<double>{0.1});
  est::MeasurementReport rep;

  auto m = meas(5.05);
  REQUIRE(ekf.update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kOk);
  CHECK(rep.fused);
  CHECK_FALSE(rep.rejected);
  const double before = ekf.state()(0);

  m = meas(before + 20.0 * std::sqrt(ekf.covariance()(0, 0) + 0.01));  // a 20-sigma glitch
  REQUIRE(ekf.update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kOk);
  CHECK(rep.rejected);
  CHECK_FALSE(rep.fused);
  CHECK(rep.test_ratio == Approx(400.0).epsilon(1e-9));
  CHECK(ekf.state()(0) == before);
  CHECK(ekf.counters().gate_rejections == 1);
  CHECK_FALSE(rep.faulty);

  REQUIRE(ekf.update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kOk);
  CHECK_FALSE(rep.faulty);
  REQUIRE(ekf.update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kOk);
  CHECK(rep.faulty);  // third rejection in a row
  m = meas(before);
  REQUIRE(ekf.update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kOk);
  CHECK(rep.fused);
  CHECK_FALSE(rep.faulty);  // a good fit clears the streak
}

TEST_CASE("unavailable and non-finite measurements are reported but never fused", "[ekf]") {
  const plant::AdModel<test::RandomWalk> model{test::RandomWalk{}};
  est::Ekf ekf(model, std::vector<double>{0.01}, 3, est::EkfOptions{});
  ekf.reset(std::vector<double>{5.0}, std::vector<double>{1.0});
  std::vector<est::Measurement> z{meas(6.0), meas(std::numeric_limits<double>::quiet_NaN()),
                                  meas(std::numeric_limits<double>::infinity())};
  z[0].available = false;
  std::vector<est::MeasurementReport> reps(3);
  REQUIRE(ekf.update(z, {}, reps) == est::StepStatus::kOk);
  for (const auto& r : reps) {
    CHECK_FALSE(r.available);
    CHECK_FALSE(r.fused);
  }
  CHECK(ekf.state()(0) == 5.0);
  CHECK(ekf.covariance()(0, 0) == 1.0);
  CHECK(ekf.counters().fused == 0);
}

TEST_CASE("a poisoned update is undone by the health check and counted", "[ekf][health]") {
  const plant::AdModel<test::SqrtSensor> model{test::SqrtSensor{}};
  est::Ekf ekf(model, std::vector<double>{0.01}, 1, est::EkfOptions{});
  ekf.reset(std::vector<double>{0.0}, std::vector<double>{0.5});  // dy/dx = inf at x = 0
  auto m = meas(0.1);
  est::MeasurementReport rep;
  CHECK(ekf.update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kNumericalReset);
  CHECK(ekf.counters().numerical_resets == 1);
  CHECK(ekf.state()(0) == 0.0);
  CHECK(ekf.covariance()(0, 0) == Approx(0.25));
  CHECK(std::isfinite(ekf.state()(0)));
}

TEST_CASE("a failed prediction keeps the state and admits more uncertainty", "[ekf][health]") {
  const plant::AdModel<Failing> model{Failing{}};
  est::Ekf ekf(model, std::vector<double>{0.1}, 1, est::EkfOptions{});
  ekf.reset(std::vector<double>{3.0}, std::vector<double>{1.0});
  CHECK(ekf.predict({}, 10.0) == est::StepStatus::kModelError);
  CHECK(ekf.state()(0) == 3.0);
  CHECK(ekf.covariance()(0, 0) == Approx(1.0 + 0.01 * 10.0));
  CHECK(ekf.counters().predict_failures == 1);
}

TEST_CASE("variances are clamped to the state's physical range", "[ekf][health]") {
  const plant::AdModel<Bounded> model{Bounded{}};
  est::Ekf ekf(model, std::vector<double>{10.0}, 1, est::EkfOptions{});
  ekf.reset(std::vector<double>{0.5}, std::vector<double>{0.1});
  REQUIRE(ekf.predict({}, 100.0) == est::StepStatus::kOk);  // adds variance 1e4
  CHECK(ekf.covariance()(0, 0) == Approx(1.0));             // (max - min)^2
}

TEST_CASE("output estimates carry delta-method standard deviations", "[ekf]") {
  const plant::AdModel<test::SqrtSensor> model{test::SqrtSensor{}};
  est::Ekf ekf(model, std::vector<double>{0.0}, 1, est::EkfOptions{});
  ekf.reset(std::vector<double>{4.0}, std::vector<double>{0.2});
  double y = 0.0, sigma = 0.0;
  REQUIRE(ekf.output_estimates({}, {&y, 1}, {&sigma, 1}) == plant::kModelOk);
  CHECK(y == Approx(2.0));
  CHECK(sigma == Approx(0.2 / (2.0 * 2.0)));  // |d sqrt(x)/dx| * sigma_x
}

TEST_CASE("an update the model cannot evaluate steps back toward the prior", "[ekf][domain]") {
  const plant::AdModel<PartDomain> model{PartDomain{}};
  for (const bool constrained : {false, true}) {
    INFO((constrained ? "constrained" : "plain") << " EKF");
    est::EkfOptions opt;
    opt.constrained = constrained;
    opt.nis_gate = 1e9;          // let the far reading in
    opt.robust_threshold = 0.0;  // at its full weight
    est::Ekf ekf(model, std::vector<double>{0.01}, 1, opt);
    ekf.reset(std::vector<double>{4.0}, std::vector<double>{3.0});
    const double prior_variance = ekf.covariance()(0, 0);
    est::MeasurementReport rep;
    auto m = meas(9.0);  // the posterior would be near 9, where the model fails
    REQUIRE(ekf.update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kOk);
    CHECK(rep.fused);
    // Halved three times: the step's eighth is the first point below 5; the variance the same
    // blend of posterior and prior (at least the partial update's).
    const double gain = 9.0 / 9.01, full = 4.0 + gain * 5.0, posterior_variance = 9.0 * 0.01 / 9.01;
    CHECK(ekf.state()(0) == Approx(4.0 + 0.125 * (full - 4.0)).epsilon(1e-9));
    CHECK(ekf.covariance()(0, 0) ==
          Approx(0.125 * posterior_variance + 0.875 * prior_variance).epsilon(1e-9));
    CHECK(ekf.posterior_step_backs() == 1);
    // And the next prediction runs (without the step back it fails, and so would every one).
    CHECK(ekf.predict({}, 1.0) == est::StepStatus::kOk);
  }
}
