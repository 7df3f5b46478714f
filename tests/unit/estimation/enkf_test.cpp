// The constrained ensemble Kalman filter: agreement with the Kalman filter on a linear model,
// independence from the number of threads, and constraints respected by every member.
#include "daemon/estimation/enkf.hpp"

#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <vector>

#include "daemon/estimation/ekf.hpp"
#include "plant_models/core/ad_model.hpp"
#include "plant_models/zone/zone_rc.hpp"
#include "test_models.hpp"
#include "tests/unit/plant_models/heat_pump_fixture.hpp"

using namespace hvac_twin;
using plant::ZoneRc;

namespace {

struct UnitInterval : test::RandomWalk {
  plant::ModelLayout layout() const {
    auto l = RandomWalk::layout();
    l.states[0].min = 0.0;
    l.states[0].max = 1.0;
    return l;
  }
};

struct Run {
  Eigen::VectorXd x;
  Eigen::MatrixXd P;
};

// The zone for 40 steps of 5 min with an air-temperature measurement each step.
template <class Filter>
Run run_zone(Filter& f) {
  const std::vector<double> x0{19.0, 18.0, 200.0}, s0{1.0, 2.0, 300.0};
  f.reset(x0, s0);
  for (int k = 0; k < 40; ++k) {
    const std::vector<double> u{2000.0 + 1500.0 * std::sin(0.3 * k), 5.0 * std::cos(0.1 * k)};
    REQUIRE(f.predict(u, 300.0) == est::StepStatus::kOk);
    const est::Measurement m{.output = ZoneRc::kZoneAirTemperature,
                             .value = 21.0 + 0.3 * std::sin(1.7 * k),
                             .variance = 0.0025,
                             .available = true};
    est::MeasurementReport rep;
    REQUIRE(f.update({&m, 1}, u, {&rep, 1}) == est::StepStatus::kOk);
  }
  return {f.state(), f.covariance()};
}

}  // namespace

TEST_CASE("the EnKF agrees with the Kalman filter on a random walk", "[enkf]") {
  // F = 1, so both filters discretise the process noise identically (Q_c dt; on coupled models
  // the EKF's trapezoid correlates it through F and the Jacobian-free EnKF cannot).
  const plant::AdModel<test::RandomWalk> model{test::RandomWalk{}};
  const double sigma_q = 0.1, dt = 10.0, r = 0.5;
  est::Ekf kf(model, std::vector<double>{sigma_q}, 1, est::EkfOptions{});
  est::EnkfOptions o;
  o.members = 2000;
  o.inflation = 1.0;
  o.constrained = false;
  est::ConstrainedEnkf enkf(model, std::vector<double>{sigma_q}, 1, o);
  for (est::Estimator* f : {static_cast<est::Estimator*>(&kf), static_cast<est::Estimator*>(&enkf)})
    f->reset(std::vector<double>{0.0}, std::vector<double>{2.0});
  for (int k = 0; k < 100; ++k) {
    const est::Measurement m{
        .output = 0, .value = std::sin(0.05 * k), .variance = r, .available = true};
    est::MeasurementReport rep;
    for (est::Estimator* f :
         {static_cast<est::Estimator*>(&kf), static_cast<est::Estimator*>(&enkf)}) {
      REQUIRE(f->predict({}, dt) == est::StepStatus::kOk);
      REQUIRE(f->update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kOk);
    }
  }
  const double qd = sigma_q * sigma_q * dt;
  const double prior = 0.5 * (qd + std::sqrt(qd * qd + 4.0 * qd * r));
  const double posterior = prior * r / (prior + r);
  const double sigma = std::sqrt(posterior);
  INFO("KF " << kf.state()(0) << ", EnKF " << enkf.state()(0) << " +- " << sigma
             << "; posterior variance " << posterior << ", EnKF " << enkf.covariance()(0, 0));
  // Sampling error with 2000 members: variances within ~sqrt(2/N) = 3 %, the mean within a
  // small fraction of sigma (the perturbed observations add their own noise).
  CHECK(kf.covariance()(0, 0) == Approx(posterior).epsilon(1e-9));
  CHECK(enkf.covariance()(0, 0) == Approx(posterior).epsilon(0.1));
  CHECK(std::abs(enkf.state()(0) - kf.state()(0)) < 0.15 * sigma);
}

TEST_CASE("the EnKF's process noise is held over the period: a stiff state forgets it", "[enkf]") {
  // Continuous white noise of intensity q on x0' = 0 and x1' = -a x1, held as a constant rate
  // over each period (zero-order hold): after dt from a known state the slow state's variance is
  // q^2 dt, the stiff one's q^2 dt ((1 - e^(-a dt)) / (a dt))^2, a millionth of it here. Added as
  // a kick after the integration, both were q^2 dt.
  const plant::AdModel<test::SlowAndStiff> model{test::SlowAndStiff{}};
  const double q = 0.2, dt = 1.0, a = test::SlowAndStiff{}.rate;
  est::EnkfOptions o;
  o.members = 2000;
  o.inflation = 1.0;
  o.constrained = false;
  est::ConstrainedEnkf enkf(model, std::vector<double>{q, q}, 2, o);
  enkf.reset(std::vector<double>{1.0, 0.0}, std::vector<double>{0.0, 0.0});
  REQUIRE(enkf.predict({}, dt) == est::StepStatus::kOk);
  const double slow = q * q * dt;
  const double stiff = slow * std::pow((1.0 - std::exp(-a * dt)) / (a * dt), 2);
  INFO("variances: slow " << enkf.covariance()(0, 0) << " (" << slow << "), stiff "
                          << enkf.covariance()(1, 1) << " (" << stiff << ")");
  // 2000 members: a sample variance within ~sqrt(2/N) = 3 % of the true one.
  CHECK(enkf.covariance()(0, 0) == Approx(slow).epsilon(0.12));
  CHECK(enkf.covariance()(1, 1) == Approx(stiff).epsilon(0.12));
  CHECK(enkf.state()(0) == Approx(1.0).margin(4.0 * std::sqrt(slow / 2000.0)));
}

TEST_CASE("the EnKF tracks the zone: errors within its own uncertainty", "[enkf]") {
  // The readings are a sinusoid no zone produces, so the innovations stay large and an ensemble's
  // sampling error in its gain (a few % with 400 members) moves the weakly observed states (the
  // building mass, the gains) by up to a sigma in a single run: 12 ensembles (seeds), their mean
  // within a quarter sigma of the Kalman filter's, their spread within a sigma, each variance
  // within 25 %. (Checked on one seed, within half a sigma, the test held for a few seeds only:
  // seed 2's building mass was 1.2 sigma off, seed 11's gains 1.0.)
  const plant::AdModel<ZoneRc> model{ZoneRc(ZoneRc::Params{})};
  const std::vector<double> q{0.01, 0.002, 2.0};
  est::EkfOptions ko;
  ko.nis_gate = 1e12;
  ko.robust_threshold = 0.0;  // both: every reading at full weight
  est::Ekf kf(model, q, 1, ko);
  const Run a = run_zone(kf);
  constexpr int kSeeds = 12;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero(), sum_sq = Eigen::Vector3d::Zero();
  for (int seed = 1; seed <= kSeeds; ++seed) {
    est::EnkfOptions eo;
    eo.members = 400;
    eo.inflation = 1.0;
    eo.nis_gate = 1e12;
    eo.robust_threshold = 0.0;
    eo.constrained = false;
    eo.seed = static_cast<std::uint64_t>(seed);
    est::ConstrainedEnkf enkf(model, q, 1, eo);
    const Run b = run_zone(enkf);
    for (int i = 0; i < 3; ++i) {
      const double d = (b.x(i) - a.x(i)) / std::sqrt(a.P(i, i));
      sum(i) += d;
      sum_sq(i) += d * d;
      INFO("seed " << seed << ", state " << i << ": KF " << a.x(i) << " +- " << std::sqrt(a.P(i, i))
                   << ", EnKF " << b.x(i) << " +- " << std::sqrt(b.P(i, i)));
      CHECK(b.P(i, i) == Approx(a.P(i, i)).epsilon(0.25));
    }
  }
  for (int i = 0; i < 3; ++i) {
    INFO("state " << i << ": EnKF - KF over the seeds, mean " << sum(i) / kSeeds << " sigma, RMS "
                  << std::sqrt(sum_sq(i) / kSeeds));
    CHECK(std::abs(sum(i) / kSeeds) < 0.25);
    CHECK(std::sqrt(sum_sq(i) / kSeeds) < 1.0);
  }
}

TEST_CASE("the EnKF gives the same result on 1 and on 3 threads", "[enkf]") {
  const plant::AdModel<ZoneRc> model{ZoneRc(ZoneRc::Params{})};
  const std::vector<double> q{0.01, 0.002, 2.0};
  est::EnkfOptions o;
  o.members = 24;
  o.threads = 1;
  est::ConstrainedEnkf one(model, q, 1, o);
  o.threads = 3;
  est::ConstrainedEnkf three(model, q, 1, o);
  const Run a = run_zone(one), b = run_zone(three);
  CHECK(a.x == b.x);
  CHECK(a.P == b.P);
  CHECK(one.members() == three.members());
}

// The heat pump carries state from one evaluation to the next (the Newton Jacobian an
// integrator keeps, the pressure solve's warm start), which the zone does not: the lanes keep
// it in a fixed chain of members, whatever thread runs them, and a model's clone does not take
// its source's (the second run clones a model that has been evaluated since the first). With
// lanes = threads, as a worker thread's chain was before the lanes, the members differ.
TEST_CASE("the EnKF on the heat pump gives the same result on 1 and on 2 threads", "[enkf]") {
  test::HeatPumpRig rig(plant::ParameterMap{{"cells", 4}, {"augment_fouling", 1}});
  auto truth = rig.start();
  const auto u = test::nominal_inputs();
  rig.run(truth, u, 1800.0);
  std::vector<double> q, s0;
  for (const auto& s : rig.model->layout().states) {
    q.push_back(s.process_noise);
    s0.push_back(s.initial_std);
  }
  // The settled truth's two pressures, offered every update of both runs.
  const auto y = rig.outputs(truth, u);
  const std::vector<est::Measurement> z{{.output = plant::hp::kSuctionPressure,
                                         .value = y[plant::hp::kSuctionPressure],
                                         .variance = 1e8,
                                         .available = true},
                                        {.output = plant::hp::kDischargePressure,
                                         .value = y[plant::hp::kDischargePressure],
                                         .variance = 1e8,
                                         .available = true}};
  const auto run = [&](std::size_t threads) {
    est::EnkfOptions o;
    o.members = 16;
    o.lanes = 4;
    o.threads = threads;
    est::ConstrainedEnkf enkf(*rig.model, q, 2, o);
    enkf.reset(truth, s0);
    for (int k = 0; k < 6; ++k) {
      REQUIRE(enkf.predict(u, 5.0) == est::StepStatus::kOk);
      std::vector<est::MeasurementReport> reports(2);
      REQUIRE(enkf.update(z, u, reports) == est::StepStatus::kOk);
    }
    return Eigen::MatrixXd(enkf.members());
  };
  const Eigen::MatrixXd one = run(1), two = run(2);
  CHECK(one.allFinite());
  CHECK(one == two);
}

TEST_CASE("every EnKF member respects the state constraints", "[enkf][constrained]") {
  const plant::AdModel<UnitInterval> model{UnitInterval{}};
  est::EnkfOptions o;
  o.members = 50;
  est::ConstrainedEnkf enkf(model, std::vector<double>{0.05}, 1, o);
  enkf.reset(std::vector<double>{0.9}, std::vector<double>{0.3});  // half the draws exceed 1
  CHECK((enkf.members().array() <= 1.0 + 1e-9).all());
  CHECK((enkf.members().array() >= -1e-9).all());
  for (int k = 0; k < 5; ++k) {
    REQUIRE(enkf.predict({}, 1.0) == est::StepStatus::kOk);
    const est::Measurement m{.output = 0, .value = 1.2, .variance = 0.01, .available = true};
    est::MeasurementReport rep;
    REQUIRE(enkf.update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kOk);
    CHECK((enkf.members().array() <= 1.0 + 1e-9).all());
    CHECK((enkf.members().array() >= -1e-9).all());
    CHECK(enkf.state()(0) <= 1.0 + 1e-9);
  }
  REQUIRE_FALSE(enkf.active_constraints().empty());
  CHECK_THAT(enkf.constraint_name(enkf.active_constraints()[0]), Catch::StartsWith("x <= 1"));
  CHECK(enkf.counters().constrained_updates > 0);
}

// The Huber weight in the EnKF (EnkfOptions::robust_threshold, est::robust_variance): a reading
// 3 innovation sigmas off is fused as from the wider noise r' = r + S (|ν|/√S / 2 - 1), in Pyy and
// in the perturbed observations: the mean moves P ν / (P + r') (2/3 as far as at full weight)
// and the spread keeps P r' / (P + r'). P is the ensemble's own prior variance, S - r.
TEST_CASE("the EnKF fuses a reading beyond the robust threshold with a Huber weight", "[enkf]") {
  const plant::AdModel<test::RandomWalk> model{test::RandomWalk{}};
  const double r = 0.01;
  for (const double c : {2.0, 0.0}) {
    INFO("threshold " << c);
    est::EnkfOptions o;
    o.members = 2000;
    o.inflation = 1.0;
    o.constrained = false;
    o.robust_threshold = c;
    est::ConstrainedEnkf enkf(model, std::vector<double>{0.0}, 1, o);
    enkf.reset(std::vector<double>{0.0}, std::vector<double>{1.0});
    const double mean0 = enkf.state()(0);
    const est::Measurement m{.output = 0, .value = 3.0, .variance = r, .available = true};
    est::MeasurementReport rep;
    REQUIRE(enkf.update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kOk);
    REQUIRE(rep.fused);
    REQUIRE(rep.test_ratio > 4.0);
    const double p = rep.innovation_variance - r;
    const double r_fused = est::robust_variance(r, rep, c);
    CHECK(
        r_fused ==
        Approx(c > 0.0 ? r + rep.innovation_variance * (std::sqrt(rep.test_ratio) / c - 1.0) : r));
    const double gain = p / (p + r_fused);
    CHECK(enkf.state()(0) - mean0 == Approx(gain * rep.innovation).epsilon(0.03));
    CHECK(enkf.covariance()(0, 0) == Approx(p * r_fused / (p + r_fused)).epsilon(0.1));
  }
}
