// Consider states (Schmidt-Kalman): no update moves them, their uncertainty is carried into
// every estimate they affect, and the covariance is the exact one of that suboptimal gain.
#include <catch2/catch.hpp>
#include <cmath>
#include <memory>
#include <vector>

#include "daemon/estimation/ekf.hpp"
#include "daemon/estimation/enkf.hpp"
#include "plant_models/core/ad_model.hpp"
#include "test_models.hpp"

using namespace hvac_twin;

namespace {

// Prior x ~ N(0, px), b ~ N(0, pb) independent; one measurement y = x + b + v, v ~ N(0, r).
constexpr double px = 4.0, pb = 1.0, r = 0.25, z = 3.0;

std::vector<est::MeasurementReport> one_update(est::Estimator& f, double value) {
  std::vector<est::Measurement> m{{0, value, r, true}};
  std::vector<est::MeasurementReport> reports(1);
  f.update(m, {}, reports);
  return reports;
}

}  // namespace

TEST_CASE("an EKF update leaves a consider state and its variance where they were, exactly",
          "[consider][ekf]") {
  const plant::AdModel<test::OffsetSensor> model(test::OffsetSensor{});
  est::Ekf ekf(model, std::vector<double>{0.0, 0.0}, 1, est::EkfOptions{});
  REQUIRE(ekf.considered(1));
  REQUIRE_FALSE(ekf.considered(0));
  ekf.reset(std::vector<double>{0.0, 0.0}, std::vector<double>{std::sqrt(px), std::sqrt(pb)});
  one_update(ekf, z);
  // Schmidt: k_x = px / s with s = px + pb + r, k_b = 0; Joseph form with that gain.
  const double s = px + pb + r, k = px / s;
  CHECK(ekf.state()(0) == Approx(k * z));
  CHECK(ekf.state()(1) == 0.0);
  const auto& P = ekf.covariance();
  CHECK(P(0, 0) == Approx((1 - k) * (1 - k) * px + k * k * (pb + r)));
  CHECK(P(0, 1) == Approx(-k * pb));
  CHECK(P(1, 1) == Approx(pb));
  // The published sigma of y = x + b carries b's uncertainty.
  std::vector<double> y(1), sigma(1);
  REQUIRE(ekf.output_estimates({}, y, sigma) == plant::kModelOk);
  CHECK(sigma[0] * sigma[0] == Approx(P(0, 0) + 2 * P(0, 1) + P(1, 1)));
  // Estimated instead, the same update moves b and shrinks its variance.
  ekf.set_consider(1, false);
  ekf.reset(std::vector<double>{0.0, 0.0}, std::vector<double>{std::sqrt(px), std::sqrt(pb)});
  one_update(ekf, z);
  CHECK(ekf.state()(1) == Approx(pb / s * z));
  CHECK(ekf.covariance()(1, 1) < pb);
}

TEST_CASE("an EnKF update leaves a consider state's members where they were", "[consider][enkf]") {
  const plant::AdModel<test::OffsetSensor> model(test::OffsetSensor{});
  est::EnkfOptions o;
  o.members = 64;
  o.threads = 1;
  o.constrained = false;
  est::ConstrainedEnkf enkf(model, std::vector<double>{0.0, 0.0}, 1, o);
  REQUIRE(enkf.considered(1));
  enkf.reset(std::vector<double>{0.0, 0.0}, std::vector<double>{std::sqrt(px), std::sqrt(pb)});
  const Eigen::MatrixXd before = enkf.members();
  one_update(enkf, z);
  CHECK(enkf.members().row(1) == before.row(1));
  CHECK((enkf.members().row(0) - before.row(0)).norm() > 0.0);
}

TEST_CASE("an EnKF predict inflates the estimated states' spread, not a consider state's",
          "[consider][enkf]") {
  const plant::AdModel<test::OffsetSensor> model(test::OffsetSensor{});
  est::EnkfOptions o;
  o.members = 64;
  o.threads = 1;
  o.inflation = 1.1;
  est::ConstrainedEnkf enkf(model, std::vector<double>{0.0, 0.0}, 1, o);
  REQUIRE(enkf.considered(1));
  enkf.reset(std::vector<double>{0.0, 0.0}, std::vector<double>{1.0, 1.0});
  const Eigen::MatrixXd before = enkf.members();
  for (int k = 0; k < 20; ++k)
    REQUIRE(enkf.predict({}, 1.0) == est::StepStatus::kOk);
  // No process noise: the estimated state's spread grows by the inflation, 1.1^20 = 6.7; the
  // consider state's stays where it was (it grew the same way before the fix).
  const auto spread = [](const Eigen::MatrixXd& X, Eigen::Index row) {
    return std::sqrt((X.row(row).array() - X.row(row).mean()).square().mean());
  };
  CHECK(spread(enkf.members(), 0) == Approx(std::pow(1.1, 20) * spread(before, 0)).epsilon(1e-9));
  CHECK(spread(enkf.members(), 1) == Approx(spread(before, 1)).epsilon(1e-9));
}

namespace {

// A part and the whole it belongs to: x' = c' = 0, y = x, and x <= c. The whole c is a consider
// state (as the heat pump's charge is while it is known from commissioning).
struct PartOfWhole : test::RandomWalk {
  plant::ModelLayout layout() const {
    plant::ModelLayout l = RandomWalk::layout();
    l.states.push_back(
        plant::StateInfo{.name = "c", .unit = "1", .abs_tol = 1e-10, .consider = true});
    l.constraints.push_back(plant::LinearConstraint{.name = "x <= c",
                                                    .over = plant::LinearConstraint::Over::kStates,
                                                    .terms = {{0, 1.0}, {1, -1.0}},
                                                    .bound = 0.0});
    return l;
  }
  template <class S>
  int rhs(std::span<const S>, std::span<const double>, std::span<S> f) const {
    f[0] = f[1] = S(0.0);
    return plant::kModelOk;
  }
};

}  // namespace

TEST_CASE("the constrained EKF projects onto a bound with the consider states held",
          "[consider][ekf][constrained]") {
  const plant::AdModel<PartOfWhole> model(PartOfWhole{});
  est::EkfOptions o;
  o.constrained = true;
  est::Ekf ekf(model, std::vector<double>{0.0, 0.0}, 1, o);
  REQUIRE(ekf.considered(1));
  // x and c correlated (rho 0.8), c known to 0.1: a measurement of x far above c.
  const double sx = 0.2, sc = 0.1, rho = 0.8;
  const std::vector<double> P0{sx * sx, rho * sx * sc, rho * sx * sc, sc * sc};
  REQUIRE(ekf.restore(std::vector<double>{0.45, 0.5}, P0, est::EstimatorCounters{}));
  std::vector<est::Measurement> m{{0, 0.9, 1e-4, true}};
  std::vector<est::MeasurementReport> reports(1);
  REQUIRE(ekf.update(m, {}, reports) == est::StepStatus::kOk);
  // The whole stays where it was and the part lands on it: the constraint holds after the
  // update. (Projecting both and then putting c back, the part would end above the whole: the
  // projection in the joint metric moves c up with x.)
  CHECK(ekf.state()(1) == 0.5);
  CHECK(ekf.state()(0) == Approx(0.5).margin(1e-12));
  REQUIRE(ekf.active_constraints().size() == 1);
  CHECK(ekf.covariance()(0, 0) > 0.0);
  CHECK(ekf.covariance()(0, 0) < P0[0]);
}

namespace {

// The constrained EKF on test::ConstrainedOutput after one update of y0 = x to `value` (prior
// x ~ N(0, px), b = b0 with variance pb), with the speed `speed`.
Eigen::VectorXd constrained_update(const test::ConstrainedOutput& m, double b0, double value,
                                   double speed) {
  const plant::AdModel<test::ConstrainedOutput> model(m);
  est::EkfOptions o;
  o.constrained = true;
  est::Ekf ekf(model, std::vector<double>{0.0, 0.0}, 1, o);
  ekf.reset(std::vector<double>{0.0, b0}, std::vector<double>{std::sqrt(px), std::sqrt(pb)});
  std::vector<est::Measurement> measured{{0, value, r, true}};
  std::vector<est::MeasurementReport> reports(1);
  const std::vector<double> u{speed};
  ekf.update(measured, u, reports);
  return ekf.state();
}

}  // namespace

TEST_CASE("an output constraint with a condition of operation holds only while it is met",
          "[consider][ekf][constraints]") {
  test::ConstrainedOutput m;
  m.conditional = true;  // y1 = x + b <= 1 while the speed is at least 5
  const double unconstrained = px / (px + r) * z;
  REQUIRE(unconstrained > 1.0);
  CHECK(constrained_update(m, 0.0, z, 10.0)(0) == Approx(1.0));           // running: projected
  CHECK(constrained_update(m, 0.0, z, 0.0)(0) == Approx(unconstrained));  // at rest: off
  m.conditional = false;
  CHECK(constrained_update(m, 0.0, z, 0.0)(0) == Approx(1.0));
}

TEST_CASE("a constraint the consider states violate does not throw the estimated states away",
          "[consider][ekf][constraints]") {
  // y1 = 1e-9 x + b <= 0 with the consider state b at 1: only x can move, by 1e9 to meet it.
  // (The heat pump at rest, its circuit held: a pressure constraint it violated drove the zone
  // air temperature, which the pressures barely depend on, to -1e29.)
  test::ConstrainedOutput m;
  m.coupling = 1e-9;
  m.bound = 0.0;
  const Eigen::VectorXd x = constrained_update(m, 1.0, 0.5, 10.0);
  CHECK(x(0) == Approx(px / (px + r) * 0.5));  // the update's own value, unprojected
  CHECK(x(1) == 1.0);
  // Where the estimated state can meet it at a fair share of the row's variance, it does.
  m.coupling = 1.0;
  CHECK(constrained_update(m, 1.0, 0.5, 10.0)(0) == Approx(-1.0));
}
