// estimation_bench --calibrate: the filters start from a batch calibration (hvac-twin-calibrate's
// est::calibrate) on a commissioning of the truth, as an installer would run it: six operating
// points held until steady (the simulator's --commissioning points, 30 degC outdoors, the zone at
// 27 degC), the charge weighed in, each window's mean measured with a tenth of a reading's noise
// (a mean over about 100 readings) and the truth's sensor bias. The fitted factors become the
// filters' initial values and their sigma the filters' initial sigma.
// Header-only; benchmarks only (allocates freely).
#pragma once

#include <cmath>
#include <cstdio>
#include <random>
#include <stdexcept>

#include "daemon/estimation/batch_calibration.hpp"
#include "daemon/estimation/steady_state.hpp"
#include "plant_models/core/settling.hpp"
#include "plant_models/heat_pump/hp_params.hpp"
#include "tests/bench/heat_pump_scenario.hpp"

namespace hvac_twin::bench {

// Sets filter_parameters() and initial_std_overrides() from a calibration on the truth `kind`.
inline void calibrate_filters(TruthKind kind) {
  using namespace plant::hp;
  const auto truth = plant::create_model("heat_pump_r32", truth_parameters(kind));
  // The filters' model as configured, then its factors as they would start uncalibrated.
  for (const auto& f : factor_info()) {
    filter_parameters().erase(f.name);
    initial_std_overrides().erase(f.name);
  }
  const auto model = plant::create_model("heat_pump_r32", filter_parameters());
  const auto& layout = model->layout();
  const std::vector<std::vector<double>> points{
      {50.0, 0.374, 1.0, 1.0, 30.0}, {35.0, 0.28, 1.0, 1.0, 30.0},  {65.0, 0.46, 1.0, 1.0, 30.0},
      {50.0, 0.374, 0.7, 1.0, 30.0}, {50.0, 0.374, 1.0, 0.6, 30.0}, {50.0, 0.33, 1.0, 1.0, 30.0}};
  est::CalibrationProblem problem;
  for (std::size_t i = 0; i < layout.states.size(); ++i) {
    const auto& s = layout.states[i];
    if (s.augmented && !s.consider && s.name != "Q_int" && s.name != "leak_rate")
      problem.parameters.push_back({i, s.initial, s.initial_std, s.min, s.max});
  }
  problem.known = {*layout.state("charge")};
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise;
  const auto truth_charge = *truth->layout().state("charge");
  est::SteadyState truth_steady(*truth, {}, {truth_charge});
  for (const auto& u : points) {
    std::vector<double> x(truth->num_states()), y(truth->num_outputs());
    const std::vector<double> none(truth->num_outputs(), std::nan(""));
    truth->initial_guess(u, none, x);
    if (!plant::settle(*truth, u, 1800.0, x) || !truth_steady.solve(u, x) ||
        truth->outputs(x, u, y) != plant::kModelOk)
      throw std::runtime_error("calibrate: the truth has no steady state at a commissioning point");
    if (kind == TruthKind::kSensorBias) y[kEvapWallTempOut] += 1.0;  // as HeatPumpTruth measures
    for (const auto& m : kMeasured) {
      if (m.output == kZoneAirTemperature) continue;  // held: no information on the factors
      const double sd = m.rel_sigma * std::abs(y[m.output]) + m.abs_sigma;
      y[m.output] += 0.1 * sd * noise(rng);
      if (&u == &points.front()) {
        problem.measured.push_back(m.output);
        problem.measured_std.push_back(std::hypot(filter_noise_factor * sd, m.repr));
      }
    }
    std::vector<double> guess(model->num_states());
    model->initial_guess(u, y, guess);
    guess[*layout.state("charge")] = x[truth_charge];
    problem.windows.push_back({u, y, guess});
  }
  const auto r = est::calibrate(*model, problem);
  if (!r.ok) throw std::runtime_error("calibrate: " + r.error);
  std::printf("commissioning calibration on the %s truth: chi-square %.1f on %zu residuals\n",
              truth_name(kind), r.chi_square, r.residuals);
  for (std::size_t k = 0; k < problem.parameters.size(); ++k) {
    const auto& name = layout.states[problem.parameters[k].state].name;
    const auto e = static_cast<Eigen::Index>(k);
    std::printf("  %-24s %.4f +- %.4f (prior %.4f +- %.4f)\n", name.c_str(), r.value[e], r.std[e],
                problem.parameters[k].prior, problem.parameters[k].prior_std);
    filter_parameters()[name] = r.value[e];
    initial_std_overrides()[name] = r.std[e];
  }
}

}  // namespace hvac_twin::bench
