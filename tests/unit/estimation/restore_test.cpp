// Estimator::restore(), what a restarted daemon resumes from a checkpoint with: a restored EKF
// continues bit-for-bit as the original would have; the EnKF's members are redrawn with the
// checkpoint's mean and covariance; bad input is refused and changes nothing.
#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <vector>

#include "daemon/estimation/ekf.hpp"
#include "daemon/estimation/enkf.hpp"
#include "plant_models/core/ad_model.hpp"
#include "plant_models/zone/zone_rc.hpp"

using namespace hvac_twin;
using plant::ZoneRc;

namespace {

const std::vector<double> kX0{19.0, 18.0, 200.0}, kStd0{1.0, 2.0, 300.0}, kNoise{0.01, 0.002, 2.0};

std::vector<double> inputs(int k) {
  return {2000.0 + 1500.0 * std::sin(0.3 * k), 5.0 * std::cos(0.1 * k)};
}

est::Measurement air(int k) {
  return {.output = ZoneRc::kZoneAirTemperature,
          .value = 21.0 + 0.3 * std::sin(1.7 * k),
          .variance = 0.0025,
          .available = true};
}

// One cycle: predict over 5 min, then fuse the air temperature.
void cycle(est::Estimator& f, int k, est::MeasurementReport& report) {
  const auto u = inputs(k);
  REQUIRE(f.predict(u, 300.0) == est::StepStatus::kOk);
  const est::Measurement m = air(k);
  REQUIRE(f.update({&m, 1}, u, {&report, 1}) == est::StepStatus::kOk);
}

std::vector<double> row_major(const Eigen::MatrixXd& P) {
  std::vector<double> out;
  for (Eigen::Index r = 0; r < P.rows(); ++r)
    for (Eigen::Index c = 0; c < P.cols(); ++c)
      out.push_back(P(r, c));
  return out;
}

bool same_counters(const est::EstimatorCounters& a, const est::EstimatorCounters& b) {
  return a.predicts == b.predicts && a.updates == b.updates && a.fused == b.fused &&
         a.gate_rejections == b.gate_rejections && a.predict_failures == b.predict_failures &&
         a.numerical_resets == b.numerical_resets && a.covariance_resets == b.covariance_resets &&
         a.constrained_updates == b.constrained_updates &&
         a.projection_failures == b.projection_failures;
}

bool identical(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() && (a.array() == b.array()).all();
}

// A positive definite covariance with correlations, as L Lᵀ.
std::vector<double> covariance() {
  Eigen::Matrix3d L;
  L << 0.5, 0.0, 0.0, 0.8, 1.5, 0.0, 40.0, -30.0, 200.0;
  return row_major(L * L.transpose());
}

struct BadInput {
  const char* name;
  std::vector<double> x, P;
};

std::vector<BadInput> bad_inputs() {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const auto P = covariance();
  std::vector<BadInput> cases{
      {"x too short", {1.0, 2.0}, P},   {"P too short", kX0, {P.begin(), P.end() - 1}},
      {"NaN in x", {1.0, nan, 3.0}, P}, {"infinite P", kX0, P},
      {"asymmetric P", kX0, P},         {"negative variance", kX0, P}};
  cases[3].P[4] = std::numeric_limits<double>::infinity();
  cases[4].P[1] *= 1.01;
  cases[5].P[8] = -1.0;
  return cases;
}

}  // namespace

TEST_CASE("a restored EKF continues bit-for-bit as the original", "[ekf][restore]") {
  const plant::AdModel<ZoneRc> model_a{ZoneRc(ZoneRc::Params{})};
  const plant::AdModel<ZoneRc> model_b{ZoneRc(ZoneRc::Params{})};
  est::Ekf a(model_a, kNoise, 1, est::EkfOptions{});
  a.reset(kX0, kStd0);
  est::MeasurementReport ra, rb;
  for (int k = 0; k < 12; ++k)
    cycle(a, k, ra);

  // The checkpoint: x, P row-major, counters; then a fresh filter as after a restart.
  const Eigen::VectorXd x = a.state();
  const auto P = row_major(a.covariance());
  est::Ekf b(model_b, kNoise, 1, est::EkfOptions{});
  b.reset(kX0, kStd0);
  REQUIRE(b.restore({x.data(), 3}, P, a.counters()));
  CHECK(identical(b.state(), a.state()));
  CHECK(identical(b.covariance(), a.covariance()));
  CHECK(same_counters(b.counters(), a.counters()));

  for (int k = 12; k < 20; ++k) {
    cycle(a, k, ra);
    cycle(b, k, rb);
    INFO("cycle " << k);
    CHECK(identical(b.state(), a.state()));
    CHECK(identical(b.covariance(), a.covariance()));
    CHECK(identical(b.transition(), a.transition()));
    CHECK(rb.innovation == ra.innovation);
    CHECK(rb.innovation_variance == ra.innovation_variance);
    CHECK(same_counters(b.counters(), a.counters()));
  }
}

TEST_CASE("the EKF refuses a bad restore and keeps its state", "[ekf][restore]") {
  const plant::AdModel<ZoneRc> model{ZoneRc(ZoneRc::Params{})};
  est::Ekf ekf(model, kNoise, 1, est::EkfOptions{});
  ekf.reset(kX0, kStd0);
  est::MeasurementReport report;
  cycle(ekf, 0, report);
  const Eigen::VectorXd x = ekf.state();
  const Eigen::MatrixXd P = ekf.covariance();
  const est::EstimatorCounters counters = ekf.counters();
  auto cases = bad_inputs();
  // Symmetric with a positive diagonal but indefinite: fails the EKF's own health criterion.
  cases.push_back({"indefinite P", kX0, {1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0}});
  est::EstimatorCounters other;
  other.predicts = 99;
  for (const BadInput& c : cases) {
    INFO(c.name);
    CHECK_FALSE(ekf.restore(c.x, c.P, other));
    CHECK(identical(ekf.state(), x));
    CHECK(identical(ekf.covariance(), P));
    CHECK(same_counters(ekf.counters(), counters));
  }
  // And it still runs.
  cycle(ekf, 1, report);
}

TEST_CASE("a restored EnKF has the checkpoint's mean and covariance", "[enkf][restore]") {
  const plant::AdModel<ZoneRc> model{ZoneRc(ZoneRc::Params{})};
  est::EnkfOptions o;
  o.members = 4000;
  o.threads = 1;
  o.constrained = false;  // a projection would move the mean
  est::ConstrainedEnkf enkf(model, kNoise, 1, o);
  enkf.reset(kX0, kStd0);
  const std::vector<double> x{21.5, 20.0, 350.0};
  const auto P = covariance();
  est::EstimatorCounters counters;
  counters.predicts = 1234;
  counters.fused = 77;
  REQUIRE(enkf.restore(x, P, counters));
  CHECK(same_counters(enkf.counters(), counters));
  for (Eigen::Index i = 0; i < 3; ++i)
    CHECK(enkf.state()(i) == Approx(x[static_cast<std::size_t>(i)]).epsilon(1e-12));
  // Sampling error of a covariance from 4000 draws: a few percent of √(Pii Pjj).
  for (Eigen::Index r = 0; r < 3; ++r)
    for (Eigen::Index c = 0; c < 3; ++c) {
      const auto R = static_cast<std::size_t>(r), C = static_cast<std::size_t>(c);
      const double scale = std::sqrt(P[R * 3 + R] * P[C * 3 + C]);
      INFO("P(" << r << "," << c << ")");
      CHECK(std::abs(enkf.covariance()(r, c) - P[R * 3 + C]) < 0.1 * scale);
    }
  est::MeasurementReport report;
  cycle(enkf, 0, report);  // and it runs on
}

TEST_CASE("the EnKF restores a singular covariance and refuses bad input", "[enkf][restore]") {
  const plant::AdModel<ZoneRc> model{ZoneRc(ZoneRc::Params{})};
  est::EnkfOptions o;
  o.members = 64;
  o.threads = 1;
  est::ConstrainedEnkf enkf(model, kNoise, 1, o);
  enkf.reset(kX0, kStd0);
  // Rank 1: every member on one line through x (an ensemble with fewer members than states is
  // singular in the same way).
  const Eigen::Vector3d v(0.5, 1.0, 30.0);
  const auto P = row_major(v * v.transpose());
  REQUIRE(enkf.restore(kX0, P, est::EstimatorCounters{}));
  CHECK(enkf.members().allFinite());
  const Eigen::MatrixXd anomalies = enkf.members().colwise() - enkf.state();
  for (Eigen::Index i = 0; i < anomalies.cols(); ++i) {
    const Eigen::Vector3d a = anomalies.col(i);
    CHECK(a.cross(v).norm() <= 1e-9 * (1.0 + a.norm() * v.norm()));
  }

  const Eigen::MatrixXd members = enkf.members();
  for (const BadInput& c : bad_inputs()) {
    INFO(c.name);
    CHECK_FALSE(enkf.restore(c.x, c.P, est::EstimatorCounters{}));
    CHECK(identical(enkf.members(), members));
  }
}
