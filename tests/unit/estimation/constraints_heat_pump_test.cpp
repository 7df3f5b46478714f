// The failure the constraints exist for (issue 4, item 7): a suction-pressure sensor that
// fails to near zero for one sample, fused while the innovation gate is open (as at a cold
// start, when the covariance is wide, or with a permissive gate).
//
// With F exact (the filters' matrix exponentials, est::filter_integrator_options) and the
// configured initial covariance, the glitch is absorbed: both filters' updates stay in range and
// both recover, the plain EKF more slowly (below). With a covariance half as wide again (1.5 x
// every initial sigma, as after a cold start or a covariance reset), the plain EKF's linearised
// update drives the liquid-line enthalpy below its physical range, where the model cannot
// evaluate: it steps back toward the prior (Ekf::keep_evaluable; before that, no prediction
// succeeded after it, for good); the constrained EKF projects each update onto the bounds and
// every state stays in range. Both recover. (With the less exact F in steady operation before,
// the plain EKF already failed for good at the configured covariance.)
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <vector>

#include "daemon/estimation/ekf.hpp"
#include "tests/unit/plant_models/heat_pump_fixture.hpp"

using namespace hvac_twin;
using namespace hvac_twin::plant::hp;

namespace {

struct Outcome {
  std::vector<double> low_side;      // charge - M_cond after each update [kg]
  std::vector<double> liquid_line;   // liquid-line enthalpy after each update [kJ/kg]
  std::vector<double> m_cond_error;  // high-side mass error after each update [kg]
  std::vector<est::StepStatus> predicts;
  double final_m_cond_error = 0.0;   // [kg]
  double final_suction_error = 0.0;  // relative
  long most_steps_failed = 0;        // integrator steps of the costliest failed prediction
  std::uint64_t step_backs = 0;      // updates stepped back into the model's domain
};

Outcome run(bool constrained, double sigma_scale,
            const plant::IntegratorOptions& integrator = est::filter_integrator_options(),
            int cycles = 60) {
  test::HeatPumpRig rig;
  auto truth = rig.start();
  const auto u = test::nominal_inputs();
  rig.run(truth, u, 1800.0);
  const auto& L = rig.model->layout();
  const auto& S = rig.hp->slots();
  std::vector<double> q, s0;
  for (const auto& s : L.states) {
    q.push_back(s.process_noise);
    s0.push_back(s.initial_std * sigma_scale);
  }
  est::EkfOptions options;
  options.constrained = constrained;
  options.integrator = integrator;
  options.nis_gate = 1e9;          // the gate is open
  options.robust_threshold = 0.0;  // and every reading at its full weight
  est::Ekf ekf(*rig.model, q, 7, options);
  ekf.reset(truth, s0);
  const std::vector<std::size_t> outs{kSuctionPressure,   kDischargePressure, kCondWallTempIn,
                                      kCondWallTempOut,   kEvapWallTempIn,    kEvapWallTempOut,
                                      kZoneAirTemperature};
  const std::vector<double> sigma{5e3, 15e3, 0.2, 0.2, 0.2, 0.2, 0.05};
  Outcome out;
  for (int k = 0; k < cycles; ++k) {
    rig.run(truth, u, 5.0, 5.0);
    const auto y = rig.outputs(truth, u);
    out.predicts.push_back(ekf.predict(u, 5.0));
    if (out.predicts.back() == est::StepStatus::kModelError)
      out.most_steps_failed = std::max(out.most_steps_failed, ekf.integrator().last_stats().steps);
    std::vector<est::Measurement> z;
    for (std::size_t i = 0; i < outs.size(); ++i)
      z.push_back({outs[i], y[outs[i]], sigma[i] * sigma[i], true});
    if (k == 0) z[0].value *= 0.02;  // the suction sensor reads 2 % of the truth, once
    std::vector<est::MeasurementReport> reports(z.size());
    ekf.update(z, u, reports);
    out.low_side.push_back(ekf.state()(static_cast<Eigen::Index>(S.charge)) -
                           ekf.state()(static_cast<Eigen::Index>(S.m_cond)));
    out.liquid_line.push_back(ekf.state()(static_cast<Eigen::Index>(S.h_ll)));
    out.final_m_cond_error = ekf.state()(static_cast<Eigen::Index>(S.m_cond)) - truth[S.m_cond];
    out.m_cond_error.push_back(out.final_m_cond_error);
    std::vector<double> ye(rig.model->num_outputs()), se(rig.model->num_outputs());
    if (ekf.output_estimates(u, ye, se) == plant::kModelOk)
      out.final_suction_error = ye[kSuctionPressure] / y[kSuctionPressure] - 1.0;
    else
      out.final_suction_error = 1.0;
  }
  out.step_backs = ekf.posterior_step_backs();
  return out;
}

}  // namespace

TEST_CASE("a glitch at the configured covariance: the exact F keeps both filters in range",
          "[ekf][constrained][heat_pump]") {
  const test::HeatPumpRig rig;
  const double h_ll_min = rig.model->layout().states[rig.hp->slots().h_ll].min;  // kJ/kg
  for (const bool constrained : {false, true}) {
    // The plain EKF is given 120 cycles. Its updates, linearised far from where they land after
    // the glitch, overshoot (seen: the high side +76, -70, +45, -143 g in the first four cycles,
    // predictions failing in two) and leave its sigma at 0.7 g with the estimate 40 g off; from
    // there it converges at about 4 % per cycle: 5.1 g off at cycle 60, 0.5 g at 120. It was
    // back by cycle 60 when F was the direct solve at its loose tolerance (0.1), but F exact to
    // 1e-3 gives the same 4.9 g: that was F's error, not the filter. The constrained EKF's
    // projection stops the overshoot: back within 0.2 g by cycle 60 either way.
    const Outcome o =
        run(constrained, 1.0, est::filter_integrator_options(), constrained ? 60 : 120);
    INFO((constrained ? "constrained" : "plain") << " EKF");
    for (std::size_t k = 0; k < o.predicts.size(); ++k) {
      INFO("cycle " << k);
      CHECK(o.low_side[k] >= 0.005);
      CHECK(o.liquid_line[k] >= h_ll_min);
      if (k >= 5) CHECK(o.predicts[k] == est::StepStatus::kOk);
    }
    CHECK(std::abs(o.final_m_cond_error) < 0.005);
    CHECK(std::abs(o.final_suction_error) < 0.01);
  }
}

TEST_CASE(
    "a glitch at a wider covariance: the plain EKF's update leaves the model's domain and steps "
    "back, the constrained EKF stays in range, both recover",
    "[ekf][constrained][heat_pump]") {
  const test::HeatPumpRig rig;
  const double h_ll_min = rig.model->layout().states[rig.hp->slots().h_ll].min;  // kJ/kg
  for (const bool constrained : {false, true}) {
    const Outcome o = run(constrained, 1.5);
    INFO((constrained ? "constrained" : "plain") << " EKF");
    for (std::size_t k = 0; k < o.predicts.size(); ++k) {
      INFO("cycle " << k << ": low side " << o.low_side[k] << " kg, liquid line "
                    << o.liquid_line[k] << " kJ/kg, prediction "
                    << static_cast<int>(o.predicts[k]));
      CHECK(o.low_side[k] >= 0.005 - 1e-9);
      CHECK(o.liquid_line[k] >= h_ll_min - 1e-9);
      if (k >= 5) CHECK(o.predicts[k] == est::StepStatus::kOk);
    }
    INFO("final high-side mass error " << o.final_m_cond_error << " kg, suction "
                                       << o.final_suction_error);
    CHECK(std::abs(o.final_m_cond_error) < 0.005);
    CHECK(std::abs(o.final_suction_error) < 0.01);
    CHECK(o.most_steps_failed <= est::kMaxPredictSteps);
    // The plain update left the model's domain (seen: the liquid line at 80 kJ/kg, range from
    // 100; before the step back every prediction after it failed, for good).
    if (!constrained) CHECK(o.step_backs >= 1);
  }
}

TEST_CASE(
    "a glitch at a wider covariance with F exact: the truncation's depth limit keeps the "
    "constrained EKF from certainty at its bound",
    "[ekf][constrained][heat_pump]") {
  // F by CVODES's direct sensitivity solve, exact to 1e-3 (the filters' exponential gives the
  // same outcome; the direct solve at its loose 0.1 hid this). The glitch drives the charge 15
  // sigma above its bound. Truncated exactly (est::EkfOptions::truncation_max_depth infinite), the
  // charge's sigma fell from 3.8 g to 0.7 g at the bound, 100 g above the truth, and 60 cycles
  // later the high side was still 29 g off (seen; 21 g with the exponential); believed at most
  // 1 sigma deep, 0.2 g.
  plant::IntegratorOptions exact = est::filter_integrator_options();
  exact.sensitivity_method = plant::SensitivityMethod::kDirect;
  exact.sensitivity_rel_tol = 1e-3;
  const Outcome o = run(true, 1.5, exact);
  INFO("final high-side mass error " << o.final_m_cond_error << " kg, suction "
                                     << o.final_suction_error);
  CHECK(std::abs(o.final_m_cond_error) < 0.005);
  CHECK(std::abs(o.final_suction_error) < 0.01);
  for (std::size_t k = 5; k < o.predicts.size(); ++k) {
    INFO("cycle " << k);
    CHECK(o.predicts[k] == est::StepStatus::kOk);
  }
}
