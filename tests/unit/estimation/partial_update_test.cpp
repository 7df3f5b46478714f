// Partial updates (Estimator::set_gain_weight): an update moves a state by its weight times the
// Kalman step, the covariance is the exact one of that gain, and StatePhases ramps the augmented
// states' weight from 0 to 1 after the settling hold.
#include <Eigen/Core>
#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "daemon/estimation/commissioning.hpp"
#include "daemon/estimation/ekf.hpp"
#include "daemon/estimation/enkf.hpp"
#include "plant_models/core/ad_model.hpp"
#include "test_models.hpp"

using namespace hvac_twin;

namespace {

// Prior x ~ N(0, px), b ~ N(0, pb) independent; one measurement y = x + b + v, v ~ N(0, r).
constexpr double px = 4.0, pb = 1.0, r = 0.25, z = 3.0;

void one_update(est::Estimator& f) {
  std::vector<est::Measurement> m{{0, z, r, true}};
  std::vector<est::MeasurementReport> reports(1);
  REQUIRE(f.update(m, {}, reports) == est::StepStatus::kOk);
  REQUIRE(reports[0].fused);
}

}  // namespace

TEST_CASE("an EKF partial update moves a state by its weight, with the exact covariance",
          "[partial][ekf]") {
  const plant::AdModel<test::OffsetSensor> model(test::OffsetSensor{.estimate_offset = true});
  est::Ekf ekf(model, std::vector<double>{0.0, 0.0}, 1, est::EkfOptions{});
  const std::vector<double> x0{0.0, 0.0}, std0{std::sqrt(px), std::sqrt(pb)};
  const double w = 0.25, s = px + pb + r;
  ekf.set_gain_weight(1, w);
  CHECK(ekf.gain_weight(1) == w);
  ekf.reset(x0, std0);
  one_update(ekf);
  // The gain (px / s, w pb / s); the Joseph form with it.
  const Eigen::Vector2d k(px / s, w * pb / s), h(1.0, 1.0);
  CHECK(ekf.state()(0) == Approx(k(0) * z));
  CHECK(ekf.state()(1) == Approx(k(1) * z));
  const Eigen::Matrix2d A = Eigen::Matrix2d::Identity() - k * h.transpose();
  const Eigen::Matrix2d expected =
      A * Eigen::Vector2d(px, pb).asDiagonal() * A.transpose() + r * k * k.transpose();
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j)
      CHECK(ekf.covariance()(i, j) == Approx(expected(i, j)));
  // Less certain than the full update, which the weight 1 (the default) gives back.
  const double partial_pbb = ekf.covariance()(1, 1);
  ekf.set_gain_weight(1, 1.0);
  ekf.reset(x0, std0);
  one_update(ekf);
  CHECK(ekf.state()(1) == Approx(pb / s * z));
  CHECK(ekf.covariance()(1, 1) < partial_pbb);
  // Weight 0 is the consider state's update exactly; weights are clamped to [0, 1].
  ekf.set_gain_weight(1, -3.0);
  CHECK(ekf.gain_weight(1) == 0.0);
  ekf.reset(x0, std0);
  one_update(ekf);
  const Eigen::Vector2d x_zero = ekf.state();
  const Eigen::Matrix2d P_zero = ekf.covariance();
  ekf.set_gain_weight(1, 1.0);
  ekf.set_consider(1, true);
  ekf.reset(x0, std0);
  one_update(ekf);
  CHECK(ekf.state() == x_zero);
  CHECK(ekf.covariance() == P_zero);
  ekf.set_gain_weight(1, 7.0);
  CHECK(ekf.gain_weight(1) == 1.0);
}

TEST_CASE("an EnKF partial update scales a state's member increments by its weight",
          "[partial][enkf]") {
  const plant::AdModel<test::OffsetSensor> model(test::OffsetSensor{.estimate_offset = true});
  est::EnkfOptions o;
  o.members = 64;
  o.threads = 1;
  o.constrained = false;
  const std::vector<double> x0{0.0, 0.0}, std0{std::sqrt(px), std::sqrt(pb)};
  // Two filters alike (the same seed): one with b at weight 0.5.
  est::ConstrainedEnkf full(model, std::vector<double>{0.0, 0.0}, 1, o);
  est::ConstrainedEnkf half(model, std::vector<double>{0.0, 0.0}, 1, o);
  half.set_gain_weight(1, 0.5);
  full.reset(x0, std0);
  half.reset(x0, std0);
  REQUIRE(full.members() == half.members());
  const Eigen::MatrixXd before = full.members();
  one_update(full);
  one_update(half);
  const Eigen::RowVectorXd full_step = full.members().row(1) - before.row(1);
  const Eigen::RowVectorXd half_step = half.members().row(1) - before.row(1);
  REQUIRE(full_step.norm() > 0.0);
  CHECK((half_step - 0.5 * full_step).norm() < 1e-12 * full_step.norm());
  CHECK(half.members().row(0) == full.members().row(0));  // x's gain is x's
}

TEST_CASE("state phases: the augmented states' gain ramps from 0 to 1 after the hold",
          "[partial][commissioning]") {
  // x physical, b augmented (estimated once released); y = x + b.
  const plant::AdModel<test::OffsetSensor> model(
      test::OffsetSensor{.estimate_offset = true, .augmented_offset = true});
  est::EkfOptions full_weight;
  full_weight.robust_threshold = 0.0;  // the update below is checked against the plain gain
  est::Ekf ekf(model, std::vector<double>(2, 0.0), 1, full_weight);
  ekf.reset(std::vector<double>{1.0, 0.0}, std::vector<double>{0.1, 0.2});
  const est::StatePhases phases(model.layout(), {}, 600.0, 0.0, 120.0);
  phases.apply(ekf, 300.0);  // held
  CHECK(ekf.considered(1));
  CHECK(ekf.gain_weight(1) == 0.0);
  phases.apply(ekf, 630.0);  // a quarter into the release
  CHECK_FALSE(ekf.considered(1));
  CHECK(ekf.gain_weight(1) == Approx(0.25));
  CHECK(ekf.gain_weight(0) == 1.0);  // the physical state is not ramped
  phases.apply(ekf, 720.0);
  CHECK(ekf.gain_weight(1) == 1.0);
  // Without a ramp, or without a hold (a resumed filter), released at once.
  const est::StatePhases at_once(model.layout(), {}, 600.0, 0.0, 0.0);
  at_once.apply(ekf, 601.0);
  CHECK(ekf.gain_weight(1) == 1.0);
  const est::StatePhases resumed(model.layout(), {}, 0.0, 0.0, 120.0);
  resumed.apply(ekf, 1.0);
  CHECK(ekf.gain_weight(1) == 1.0);
  CHECK_FALSE(resumed.releasing(1.0));
  // Resumed from a checkpoint saved before the release was complete: the ramp from the resume.
  const est::StatePhases ramp = est::StatePhases::resumed_ramp(model.layout(), 120.0);
  ramp.apply(ekf, 0.0);
  CHECK_FALSE(ekf.considered(1));
  CHECK(ekf.gain_weight(1) == 0.0);
  ramp.apply(ekf, 90.0);
  CHECK(ekf.gain_weight(1) == Approx(0.75));
  CHECK(ramp.releasing(90.0));
  ramp.apply(ekf, 120.0);
  CHECK(ekf.gain_weight(1) == 1.0);
  CHECK_FALSE(ramp.releasing(120.0));
  // What a checkpoint records (kSnapshotReleasing): held or ramping until the ramp's end.
  CHECK(phases.releasing(300.0));
  CHECK(phases.releasing(630.0));
  CHECK_FALSE(phases.releasing(720.0));

  // Mid-ramp, an update moves the parameter by the weight times its full step.
  phases.apply(ekf, 660.0);
  REQUIRE(ekf.gain_weight(1) == Approx(0.5));
  std::vector<est::MeasurementReport> reports(1);
  const std::vector<est::Measurement> m{
      {.output = 0, .value = 1.5, .variance = 0.01, .available = true}};
  REQUIRE(ekf.update(m, {}, reports) == est::StepStatus::kOk);
  const double s = 0.01 + 0.04 + 0.01;
  CHECK(ekf.state()(1) == Approx(0.5 * 0.04 / s * 0.5));
}
