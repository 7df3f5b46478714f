// The update and the published sigma reuse the last output Jacobian while no state is further
// from where it was evaluated than the integrator's Jacobian-reuse distance and no input further
// than that in units of its reuse_scale (Ekf::outputs_with_jacobian), and evaluate it afresh
// otherwise. Checked on the heat pump, whose output Jacobian changes with the state,
// against sigma from an output Jacobian evaluated at the estimate (the filter's own part of the
// published sigma: Estimator::output_estimates adds the outputs' structural error).
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "daemon/estimation/ekf.hpp"
#include "plant_models/catalog.hpp"
#include "plant_models/core/integrator.hpp"

using namespace hvac_twin;

namespace {

struct Fixture {
  std::unique_ptr<plant::ContinuousModel> model =
      plant::create_model("heat_pump_r32", {{"augment_fouling", 1}, {"augment_void_exponent", 1}});
  const std::vector<double> u{50.0, 0.374, 1.0, 1.0, 35.0};
  std::vector<double> q, s0, x0;

  Fixture() {
    for (const auto& s : model->layout().states) {
      q.push_back(s.process_noise);
      s0.push_back(0.05 * s.initial_std);
      x0.push_back(s.initial);
    }
    REQUIRE(plant::Integrator(*model, {}).step(x0, u, 600.0, {}).ok());
  }

  // Resets the filter at the settled state and predicts one second: the outputs at the prior.
  std::vector<double> start(est::Ekf& ekf) const {
    ekf.reset(x0, s0);
    REQUIRE(ekf.predict(u, 1.0) == est::StepStatus::kOk);
    std::vector<double> y(model->num_outputs());
    const std::vector<double> x(ekf.state().data(), ekf.state().data() + ekf.num_states());
    REQUIRE(model->outputs(x, u, y) == plant::kModelOk);
    return y;
  }

  // sigma of every output from H evaluated at the filter's estimate and its P.
  std::vector<double> fresh_sigma(const est::Ekf& ekf) const {
    const auto n = static_cast<Eigen::Index>(model->num_states());
    const auto m = static_cast<Eigen::Index>(model->num_outputs());
    Eigen::MatrixXd H(m, n);
    std::vector<double> y(model->num_outputs());
    const std::vector<double> x(ekf.state().data(), ekf.state().data() + n);
    REQUIRE(model->output_jacobian(x, u, y, {H.data(), static_cast<std::size_t>(H.size())}) ==
            plant::kModelOk);
    const Eigen::MatrixXd S = H * ekf.covariance() * H.transpose();
    std::vector<double> sigma;
    for (Eigen::Index r = 0; r < m; ++r)
      sigma.push_back(std::sqrt(std::max(0.0, S(r, r))));
    return sigma;
  }
};

// The largest relative difference of two sigma vectors, over the outputs with sigma above 0.
double worst_relative(const std::vector<double>& a, const std::vector<double>& b) {
  double worst = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (b[i] > 0.0) worst = std::max(worst, std::abs(a[i] - b[i]) / b[i]);
  return worst;
}

}  // namespace

TEST_CASE("published sigma: the update's output Jacobian while the state stays near it",
          "[ekf][output_jacobian]") {
  Fixture f;
  est::EkfOptions o;
  o.nis_gate = 1e9;          // a reading far off is fused, not gated out
  o.robust_threshold = 0.0;  // and at full weight
  est::Ekf ekf(*f.model, f.q, 1, o);
  std::vector<double> y = f.start(ekf), sigma(y.size()), own(y.size());
  est::MeasurementReport rep;

  SECTION("a reading that agrees with the prior moves nothing: reused, sigma the same") {
    const est::Measurement z{.output = 0, .value = y[0], .variance = 1e8, .available = true};
    REQUIRE(ekf.update({&z, 1}, f.u, {&rep, 1}) == est::StepStatus::kOk);
    CHECK(ekf.output_jacobian_reuses() == 0);  // the update's own, evaluated at the prior
    REQUIRE(ekf.output_estimates(f.u, y, sigma, own) == plant::kModelOk);
    CHECK(ekf.output_jacobian_reuses() == 1);
    CHECK(worst_relative(own, f.fresh_sigma(ekf)) < 1e-12);
    // A second call at the same estimate still has it; an input moved by a fifth of its reuse
    // distance too (the compressor's speed: reuse_scale 5 Hz, distance 0.05 of it); one moved
    // by four times that distance does not.
    REQUIRE(ekf.output_estimates(f.u, y, sigma, own) == plant::kModelOk);
    CHECK(ekf.output_jacobian_reuses() == 2);
    std::vector<double> u2 = f.u;
    u2[0] += 0.05;
    REQUIRE(ekf.output_estimates(u2, y, sigma, own) == plant::kModelOk);
    CHECK(ekf.output_jacobian_reuses() == 3);
    u2[0] = f.u[0] + 1.0;
    REQUIRE(ekf.output_estimates(u2, y, sigma, own) == plant::kModelOk);
    CHECK(ekf.output_jacobian_reuses() == 3);
    CHECK(ekf.output_estimate_calls() == 5);
  }
  SECTION("a reading a little off moves the state a little: reused, sigma within 1 %") {
    const est::Measurement z{
        .output = 0, .value = y[0] * (1.0 + 3e-4), .variance = 1e8, .available = true};
    const Eigen::VectorXd prior = ekf.state();
    REQUIRE(ekf.update({&z, 1}, f.u, {&rep, 1}) == est::StepStatus::kOk);
    REQUIRE((ekf.state() - prior).norm() > 0.0);
    REQUIRE(ekf.output_estimates(f.u, y, sigma, own) == plant::kModelOk);
    CHECK(ekf.output_jacobian_reuses() == 1);
    CHECK(worst_relative(own, f.fresh_sigma(ekf)) < 1e-2);
  }
  SECTION("an update that moves the state far: evaluated at the estimate, sigma exact") {
    const est::Measurement z{.output = 0, .value = y[0] * 1.02, .variance = 1e6, .available = true};
    REQUIRE(ekf.update({&z, 1}, f.u, {&rep, 1}) == est::StepStatus::kOk);
    REQUIRE(rep.fused);
    REQUIRE(ekf.output_estimates(f.u, y, sigma, own) == plant::kModelOk);
    CHECK(ekf.output_jacobian_reuses() == 0);
    CHECK(worst_relative(own, f.fresh_sigma(ekf)) < 1e-12);
  }
  SECTION("steady operation: the next cycles' updates and sigma reuse it, sigma within 1 %") {
    const est::Measurement z{.output = 0, .value = y[0], .variance = 1e8, .available = true};
    REQUIRE(ekf.update({&z, 1}, f.u, {&rep, 1}) == est::StepStatus::kOk);
    for (int k = 0; k < 3; ++k) {
      REQUIRE(ekf.predict(f.u, 1.0) == est::StepStatus::kOk);
      REQUIRE(ekf.update({&z, 1}, f.u, {&rep, 1}) == est::StepStatus::kOk);
      REQUIRE(ekf.output_estimates(f.u, y, sigma, own) == plant::kModelOk);
    }
    CHECK(ekf.output_jacobian_reuses() == 6);
    CHECK(ekf.output_estimate_calls() == 7);
    CHECK(worst_relative(own, f.fresh_sigma(ekf)) < 1e-2);
  }
}

TEST_CASE("published sigma: no reuse at a reuse distance of 0", "[ekf][output_jacobian]") {
  Fixture f;
  est::EkfOptions o;
  o.integrator.jacobian_reuse_sigma = 0.0;
  est::Ekf ekf(*f.model, f.q, 1, o);
  std::vector<double> y = f.start(ekf), sigma(y.size()), own(y.size());
  est::MeasurementReport rep;
  const est::Measurement z{.output = 0, .value = y[0], .variance = 1e8, .available = true};
  REQUIRE(ekf.update({&z, 1}, f.u, {&rep, 1}) == est::StepStatus::kOk);
  REQUIRE(ekf.output_estimates(f.u, y, sigma, own) == plant::kModelOk);
  CHECK(ekf.output_jacobian_reuses() == 0);
  CHECK(worst_relative(own, f.fresh_sigma(ekf)) < 1e-12);
}
