// The failure the constraints exist for (issue 4, item 7): a suction-pressure sensor that
// fails to near zero for one sample, fused while the innovation gate is open (as at a cold
// start, when the covariance is wide, or with a permissive gate). The plain EKF's linearised
// update nearly empties the low side and drives the liquid-line enthalpy to the bottom of its
// physical range; within two cycles it reaches a state no prediction succeeds from, and the
// filter never recovers. The constrained EKF projects each update onto the bounds: its low side
// keeps refrigerant and every state stays in range. Right after the glitch the nearly empty low
// side may still be pumped down past what the model can resolve (failed predictions: x kept,
// P inflated), after which it predicts again and converges back to the truth.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
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
};

Outcome run(bool constrained) {
  test::HeatPumpRig rig;
  auto truth = rig.start();
  const auto u = test::nominal_inputs();
  rig.run(truth, u, 1800.0);
  const auto& L = rig.model->layout();
  const auto& S = rig.hp->slots();
  std::vector<double> q, s0;
  for (const auto& s : L.states) {
    q.push_back(s.process_noise);
    s0.push_back(s.initial_std);
  }
  est::EkfOptions options;
  options.constrained = constrained;
  options.nis_gate = 1e9;  // the gate is open
  est::Ekf ekf(*rig.model, q, 7, options);
  ekf.reset(truth, s0);
  const std::vector<std::size_t> outs{kSuctionPressure,   kDischargePressure, kCondWallTempIn,
                                      kCondWallTempOut,   kEvapWallTempIn,    kEvapWallTempOut,
                                      kZoneAirTemperature};
  const std::vector<double> sigma{5e3, 15e3, 0.2, 0.2, 0.2, 0.2, 0.05};
  Outcome out;
  for (int k = 0; k < 60; ++k) {
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
  return out;
}

}  // namespace

TEST_CASE(
    "a glitch drives the plain EKF out of the physical range for good, the constrained "
    "EKF stays physical and recovers",
    "[ekf][constrained][heat_pump]") {
  const Outcome plain = run(false);
  const Outcome constrained = run(true);
  const test::HeatPumpRig rig;
  const double h_ll_min = rig.model->layout().states[rig.hp->slots().h_ll].min;  // kJ/kg
  // Plain: within two cycles it reaches a state no prediction succeeds from, and stays there
  // for good: every later prediction fails and nothing changes. (Seen with the quality-dependent
  // two-phase closure: the liquid-line enthalpy at 108 kJ/kg, near the bottom of its range, after
  // the glitch, every prediction failing from cycle 2, frozen with the high side 10 g off; with
  // the glitch at 1 % of the truth, frozen with the low side at -11 g. With the constant closure
  // before it the enthalpy left its range in cycle 1.)
  const auto first_failed = static_cast<std::size_t>(
      std::find(plain.predicts.begin(), plain.predicts.end(), est::StepStatus::kModelError) -
      plain.predicts.begin());
  REQUIRE(first_failed <= 2);
  for (std::size_t k = first_failed; k < plain.predicts.size(); ++k) {
    INFO("cycle " << k);
    CHECK(plain.predicts[k] == est::StepStatus::kModelError);
    CHECK(plain.low_side[k] == plain.low_side[first_failed]);
    CHECK(plain.liquid_line[k] == plain.liquid_line[first_failed]);
  }
  CHECK(plain.liquid_line[0] < h_ll_min + 0.1 * (plain.liquid_line[first_failed] - h_ll_min));
  // Constrained: never below the bounds (the low side keeps 1 % of the nameplate charge), failed
  // predictions only while the nearly empty low side is pumped down right after the glitch
  // (seen: cycles 1 and 2), every one after that succeeds, and the estimate converges back:
  // the high-side mass error at the end is a third of its largest after those cycles or less
  // (seen: 98 g at cycle 6, 31 g at cycle 54, 17 g at cycle 70).
  double worst_after = 0.0;
  for (std::size_t k = 0; k < constrained.predicts.size(); ++k) {
    INFO("cycle " << k << ": low side " << constrained.low_side[k] << " kg");
    CHECK(constrained.low_side[k] >= 0.005 - 1e-9);
    CHECK(constrained.liquid_line[k] >= h_ll_min - 1e-9);
    if (k >= 5) {
      CHECK(constrained.predicts[k] == est::StepStatus::kOk);
      worst_after = std::max(worst_after, std::abs(constrained.m_cond_error[k]));
    }
  }
  INFO("constrained after 60 cycles: M_cond error "
       << constrained.final_m_cond_error << " kg (largest after cycle 5: " << worst_after
       << " kg), suction error " << constrained.final_suction_error);
  CHECK(std::abs(constrained.final_m_cond_error) < worst_after / 3.0);
  // A failed prediction gives up within the filters' step budget (it ground through 20000
  // steps, 40 s, before the budget existed).
  CHECK(plain.most_steps_failed <= est::kMaxPredictSteps);
  CHECK(constrained.most_steps_failed <= est::kMaxPredictSteps);
  CHECK(std::abs(constrained.final_suction_error) < 0.01);
}
