// The EKF on linear systems, where the Kalman filter has a closed form to compare against.
#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <unsupported/Eigen/MatrixFunctions>
#include <vector>

#include "daemon/estimation/ekf.hpp"
#include "plant_models/core/ad_model.hpp"
#include "plant_models/zone/zone_rc.hpp"
#include "test_models.hpp"

using namespace hvac_twin;
using plant::ZoneRc;

namespace {

// The zone model as z' = M z with z = [T_air, T_mass, Q_int, 1], written independently of the
// model source.
Eigen::Matrix4d zone_matrix(const ZoneRc::Params& p, double q_hp, double t_out) {
  Eigen::Matrix4d M = Eigen::Matrix4d::Zero();
  M(0, 0) = -(p.ua_air_mass + p.ua_air_out) / p.c_air;
  M(0, 1) = p.ua_air_mass / p.c_air;
  M(0, 2) = p.gain_fraction_air / p.c_air;
  M(0, 3) = (p.ua_air_out * t_out + p.hp_fraction_air * q_hp) / p.c_air;
  M(1, 0) = p.ua_air_mass / p.c_mass;
  M(1, 1) = -(p.ua_air_mass + p.ua_mass_out) / p.c_mass;
  M(1, 2) = (1.0 - p.gain_fraction_air) / p.c_mass;
  M(1, 3) = (p.ua_mass_out * t_out + (1.0 - p.hp_fraction_air) * q_hp) / p.c_mass;
  return M;
}

// Accurate F: tight tolerances with the sensitivities in the error test, since these tests
// compare the filter's algebra with a closed form (the default trades F accuracy for speed).
est::EkfOptions tight_options() {
  est::EkfOptions o;
  o.integrator.rel_tol = 1e-10;
  o.integrator.abs_tol_scale = 1e-3;
  o.integrator.sensitivity_error_control = true;
  o.integrator.sensitivity_rel_tol = 0.0;  // F at rel_tol too, not the filters' looser 0.1
  return o;
}

struct Scenario {
  double q_hp, t_out;
};

Scenario scenario(int k) {
  return {2000.0 + 1500.0 * std::sin(0.3 * k), 5.0 * std::cos(0.1 * k)};
}

}  // namespace

TEST_CASE("EKF on the linear zone model equals the closed-form Kalman filter", "[ekf]") {
  const ZoneRc::Params p;
  const plant::AdModel<ZoneRc> model{ZoneRc(p)};
  const std::vector<double> q{0.01, 0.002, 2.0};
  const double r = 0.05 * 0.05, dt = 300.0;
  auto opt = tight_options();
  opt.nis_gate = 1e12;         // the textbook filter has no gate
  opt.robust_threshold = 0.0;  // and no Huber weight
  est::Ekf ekf(model, q, 1, opt);
  const std::vector<double> x0{19.0, 18.0, 200.0}, s0{1.0, 2.0, 300.0};
  ekf.reset(x0, s0);

  Eigen::Vector3d x(x0.data());
  Eigen::Matrix3d P = Eigen::Vector3d(s0[0] * s0[0], s0[1] * s0[1], s0[2] * s0[2]).asDiagonal();
  const Eigen::Matrix3d Qc = Eigen::Vector3d(q[0] * q[0], q[1] * q[1], q[2] * q[2]).asDiagonal();
  const Eigen::RowVector3d H(1.0, 0.0, 0.0);

  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.3);
  for (int k = 0; k < 60; ++k) {
    const Scenario s = scenario(k);
    const Eigen::Matrix4d E = (zone_matrix(p, s.q_hp, s.t_out) * dt).exp();
    const Eigen::Matrix3d F = E.topLeftCorner<3, 3>();
    x = F * x + E.topRightCorner<3, 1>();
    P = F * P * F.transpose() + 0.5 * dt * (F * Qc * F.transpose() + Qc);
    const double z = 21.0 + noise(rng);
    const double S = (H * P * H.transpose())(0, 0) + r;
    const Eigen::Vector3d K = P * H.transpose() / S;
    x += K * (z - H * x);
    P = (Eigen::Matrix3d::Identity() - K * H) * P;

    const std::vector<double> u{s.q_hp, s.t_out};
    REQUIRE(ekf.predict(u, dt) == est::StepStatus::kOk);
    const est::Measurement m{
        .output = ZoneRc::kZoneAirTemperature, .value = z, .variance = r, .available = true};
    est::MeasurementReport rep;
    REQUIRE(ekf.update({&m, 1}, u, {&rep, 1}) == est::StepStatus::kOk);
    REQUIRE(rep.fused);
    CHECK(rep.innovation_variance == Approx(S).epsilon(1e-6));
    for (int i = 0; i < 3; ++i) {
      CHECK(ekf.state()(i) == Approx(x(i)).epsilon(1e-6));
      for (int j = 0; j < 3; ++j)
        CHECK(ekf.covariance()(i, j) ==
              Approx(P(i, j)).epsilon(1e-5).margin(1e-9 * std::sqrt(P(i, i) * P(j, j))));
    }
  }
}

TEST_CASE("EKF on a random walk converges to the closed-form steady-state covariance", "[ekf]") {
  const plant::AdModel<test::RandomWalk> model{test::RandomWalk{}};
  const double sigma_q = 0.1, dt = 10.0, r = 0.5;
  est::Ekf ekf(model, std::vector<double>{sigma_q}, 1, tight_options());
  ekf.reset(std::vector<double>{0.0}, std::vector<double>{10.0});
  const double qd = sigma_q * sigma_q * dt;
  const double prior = 0.5 * (qd + std::sqrt(qd * qd + 4.0 * qd * r));  // Riccati fixed point
  const double posterior = prior * r / (prior + r);
  for (int k = 0; k < 200; ++k) {
    REQUIRE(ekf.predict({}, dt) == est::StepStatus::kOk);
    if (k == 199) CHECK(ekf.covariance()(0, 0) == Approx(prior).epsilon(1e-9));
    const est::Measurement m{.output = 0, .value = 1.0, .variance = r, .available = true};
    est::MeasurementReport rep;
    REQUIRE(ekf.update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kOk);
  }
  CHECK(ekf.covariance()(0, 0) == Approx(posterior).epsilon(1e-9));
  CHECK(ekf.state()(0) == Approx(1.0).epsilon(1e-6));
}

TEST_CASE("EKF is consistent: time-averaged NIS inside the 95% chi-square band", "[ekf]") {
  // Truth simulated with the very noise the filter assumes; N = 1000 scalar innovations give the
  // band [0.914, 1.090] of reliability.md. Fixed seed: deterministic.
  const ZoneRc::Params p;
  const plant::AdModel<ZoneRc> model{ZoneRc(p)};
  const std::vector<double> q{0.005, 0.001, 1.0};
  const double r = 0.1 * 0.1, dt = 120.0;
  est::Ekf ekf(model, q, 1, tight_options());
  const std::vector<double> x0{20.0, 20.0, 300.0}, s0{0.5, 1.0, 200.0};
  ekf.reset(x0, s0);

  std::mt19937 rng(2024);
  std::normal_distribution<double> g(0.0, 1.0);
  Eigen::Vector3d truth(x0[0] + s0[0] * g(rng), x0[1] + s0[1] * g(rng), x0[2] + s0[2] * g(rng));
  const Eigen::Matrix3d Qc = Eigen::Vector3d(q[0] * q[0], q[1] * q[1], q[2] * q[2]).asDiagonal();
  double nis_sum = 0.0;
  const int N = 1000;
  for (int k = 0; k < N; ++k) {
    const Scenario s = scenario(k);
    const Eigen::Matrix4d E = (zone_matrix(p, s.q_hp, s.t_out) * dt).exp();
    const Eigen::Matrix3d F = E.topLeftCorner<3, 3>();
    const Eigen::Matrix3d Qd = 0.5 * dt * (F * Qc * F.transpose() + Qc);
    const Eigen::Matrix3d L = Qd.llt().matrixL();
    truth = F * truth + E.topRightCorner<3, 1>() + L * Eigen::Vector3d(g(rng), g(rng), g(rng));
    const std::vector<double> u{s.q_hp, s.t_out};
    REQUIRE(ekf.predict(u, dt) == est::StepStatus::kOk);
    const est::Measurement m{.output = ZoneRc::kZoneAirTemperature,
                             .value = truth(0) + std::sqrt(r) * g(rng),
                             .variance = r,
                             .available = true};
    est::MeasurementReport rep;
    REQUIRE(ekf.update({&m, 1}, u, {&rep, 1}) == est::StepStatus::kOk);
    nis_sum += rep.test_ratio;
  }
  const double nis = nis_sum / N;
  INFO("time-averaged NIS " << nis);
  CHECK(nis > 0.914);
  CHECK(nis < 1.090);
}

// The Huber weight (EkfOptions::robust_threshold): x = 0 with P = 1 and a reading of noise r.
// Within c = 2 innovation sigmas the textbook update; beyond, the reading is fused as if its
// variance were R' = r + S (|ν|/√S / c - 1), the gain P / (P + R'), and the Joseph form's P the
// covariance of that update, P R' / (P + R'). The gate's report keeps the prior's S.
TEST_CASE("a reading beyond the robust threshold is fused with a Huber weight", "[ekf]") {
  const plant::AdModel<test::RandomWalk> model{test::RandomWalk{}};
  const std::vector<double> q{0.0}, x0{0.0}, s0{1.0};
  const double r = 0.01, s = 1.0 + r;
  for (const double z : {1.0, -1.5, 2.5, -3.2}) {
    for (const double c : {2.0, 0.0}) {
      INFO("reading " << z << ", threshold " << c);
      est::EkfOptions o;
      o.robust_threshold = c;
      est::Ekf ekf(model, q, 1, o);
      ekf.reset(x0, s0);
      est::Measurement m{.output = 0, .value = z, .variance = r, .available = true};
      est::MeasurementReport rep;
      REQUIRE(ekf.update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kOk);
      REQUIRE(rep.fused);
      CHECK(rep.innovation_variance == Approx(s).epsilon(1e-12));
      const double ratio = std::abs(z) / std::sqrt(s);
      const double r_fused = c > 0.0 && ratio > c ? r + s * (ratio / c - 1.0) : r;
      CHECK(ekf.state()(0) == Approx(z / (1.0 + r_fused)).epsilon(1e-12));
      CHECK(ekf.covariance()(0, 0) == Approx(r_fused / (1.0 + r_fused)).epsilon(1e-12));
    }
  }
}
