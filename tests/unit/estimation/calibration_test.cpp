// Batch calibration on steady windows (daemon/estimation/batch_calibration.hpp): the steady state
// and its parameter sensitivities against finite differences, and the parameters of a perturbed
// truth recovered within their reported sigma.
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "daemon/estimation/batch_calibration.hpp"
#include "daemon/estimation/steady_state.hpp"
#include "plant_models/core/settling.hpp"
#include "plant_models/heat_pump/hp_layout.hpp"
#include "tests/unit/plant_models/heat_pump_fixture.hpp"

namespace {

using hvac_twin::est::CalibrationProblem;
using hvac_twin::est::SteadyState;
namespace hp = hvac_twin::plant::hp;

constexpr const char* kFitted[] = {"fouling", "evap_ua_factor", "comp_flow_factor", "valve_factor",
                                   "comp_efficiency_factor"};

hvac_twin::plant::ParameterMap augmented(hvac_twin::plant::ParameterMap p = {}) {
  for (const char* f : kFitted)
    p[std::string("augment_") + f] = 1.0;
  return p;
}

std::vector<std::size_t> states(const hvac_twin::plant::ContinuousModel& m) {
  std::vector<std::size_t> s;
  for (const char* f : kFitted)
    s.push_back(*m.layout().state(f));
  return s;
}

// Operating points a commissioning engineer would hold: speed, valve, fans, outdoor temperature.
std::vector<std::vector<double>> operating_points() {
  return {{50.0, 0.374, 1.0, 1.0, 35.0}, {35.0, 0.28, 1.0, 1.0, 35.0},
          {65.0, 0.46, 1.0, 1.0, 35.0},  {50.0, 0.374, 0.7, 1.0, 30.0},
          {50.0, 0.374, 1.0, 0.6, 30.0}, {50.0, 0.33, 1.0, 1.0, 27.0}};
}

// The steady state of the rig's model at u, the fitted factors at p, the charge 0.5 kg.
std::vector<double> steady(const hvac_twin::test::HeatPumpRig& rig, const std::vector<double>& u,
                           const std::vector<double>& p) {
  auto x = rig.start(u[4], 27.0, 0.5);
  const auto s = states(*rig.model);
  for (std::size_t k = 0; k < s.size(); ++k)
    x[s[k]] = p[k];
  REQUIRE(hvac_twin::plant::settle(*rig.model, u, 1200.0, x));
  SteadyState steady(*rig.model, s, {*rig.model->layout().state("charge")});
  INFO(steady.error());
  REQUIRE(steady.solve(u, x));
  return x;
}

}  // namespace

TEST_CASE("a steady state solves f = 0 and its parameter sensitivities match finite differences",
          "[calibration]") {
  const hvac_twin::test::HeatPumpRig rig(augmented());
  const auto u = hvac_twin::test::nominal_inputs();
  const std::vector<double> p{1.0, 1.0, 1.0, 1.0, 1.0};
  auto x = steady(rig, u, p);
  SteadyState steady(*rig.model, states(*rig.model), {*rig.model->layout().state("charge")});
  std::vector<double> f(x.size());
  REQUIRE(rig.model->rhs(x, u, f) == 0);
  for (const std::size_t i : steady.free_states()) {
    INFO(rig.model->layout().states[i].name);
    CHECK(std::abs(f[i]) < 1e-4 * std::max(1.0, std::abs(x[i])));
  }
  Eigen::VectorXd y;
  Eigen::MatrixXd dy;
  REQUIRE(steady.sensitivities(u, x, y, dy));
  const auto s = states(*rig.model);
  for (std::size_t k = 0; k < s.size(); ++k) {
    const double h = 1e-4;
    auto solve_at = [&](double v) {
      auto xs = x;
      xs[s[k]] = v;
      REQUIRE(steady.solve(u, xs));
      return rig.outputs(xs, u);
    };
    const auto up = solve_at(p[k] + h), down = solve_at(p[k] - h);
    for (const auto o : {hp::kSuctionPressure, hp::kDischargePressure, hp::kCondWallTempOut,
                         hp::kEvapWallTempOut, hp::kSuperheat}) {
      const double fd = (up[o] - down[o]) / (2 * h);
      INFO(kFitted[k] << " -> " << rig.model->layout().outputs[o].name << ": AD " << dy(o, k)
                      << ", FD " << fd);
      CHECK(dy(o, static_cast<Eigen::Index>(k)) ==
            Approx(fd).margin(1e-3 * (std::abs(y[o]) + 1.0)).epsilon(1e-3));
    }
  }
}

// Six steady windows of the truth with every sensor's noise drawn from `seed`.
struct Commissioning {
  const hvac_twin::test::HeatPumpRig rig{augmented()};
  const std::vector<double> truth{0.85, 1.12, 0.95, 0.9, 1.06};
  const std::vector<std::size_t> measured{hp::kSuctionPressure, hp::kDischargePressure,
                                          hp::kCondWallTempIn,  hp::kCondWallTempOut,
                                          hp::kEvapWallTempIn,  hp::kEvapWallTempOut};
  const std::vector<double> noise{5000.0, 15000.0, 0.2, 0.2, 0.2, 0.2};
  std::vector<std::vector<double>> clean;  // the truth's outputs, window by window

  Commissioning() {
    for (const auto& u : operating_points())
      clean.push_back(rig.outputs(steady(rig, u, truth), u));
  }

  // bias: each sensor's offset in the data (empty: none).
  CalibrationProblem problem(unsigned seed, const std::vector<double>& bias = {}) const {
    const auto& layout = rig.model->layout();
    CalibrationProblem problem;
    for (const std::size_t i : states(*rig.model))
      problem.parameters.push_back({i, layout.states[i].initial, layout.states[i].initial_std,
                                    layout.states[i].min, layout.states[i].max});
    problem.known = {*layout.state("charge")};
    problem.measured = measured;
    problem.measured_std = noise;
    std::mt19937 rng(seed);
    std::normal_distribution<double> normal;
    const auto points = operating_points();
    for (std::size_t w = 0; w < points.size(); ++w) {
      auto y = clean[w];
      for (std::size_t k = 0; k < measured.size(); ++k)
        y[measured[k]] += noise[k] * normal(rng) + (bias.empty() ? 0.0 : bias[k]);
      problem.windows.push_back({points[w], y, rig.start(points[w][4], 27.0, 0.5)});
    }
    return problem;
  }
};

TEST_CASE("calibration recovers a perturbed truth's factors within their reported sigma",
          "[calibration]") {
  const Commissioning c;
  const auto problem = c.problem(7);
  const auto result = hvac_twin::est::calibrate(*c.rig.model, problem);
  INFO(result.error);
  REQUIRE(result.ok);
  for (const auto& w : result.windows)
    CHECK(w.used);
  CHECK(result.chi_square < result.chi_square_nominal / 10.0);
  CHECK(result.residuals == 36);
  for (std::size_t k = 0; k < c.truth.size(); ++k) {
    const auto e = static_cast<Eigen::Index>(k);
    INFO(kFitted[k] << ": truth " << c.truth[k] << ", fit " << result.value[e] << " +- "
                    << result.std[e] << " (prior sigma " << problem.parameters[k].prior_std << ")");
    CHECK(std::abs(result.value[e] - c.truth[k]) < 3.0 * result.std[e]);
    // The windows determined it: its sigma is well below the prior's.
    CHECK(result.std[e] < problem.parameters[k].prior_std / 2.0);
  }
}

TEST_CASE("calibration's sigma is honest: the parameters' NEES over noise draws is in its band",
          "[calibration]") {
  const Commissioning c;
  constexpr unsigned kDraws = 12;
  double nees = 0.0;
  for (unsigned seed = 1; seed <= kDraws; ++seed) {
    const auto result = hvac_twin::est::calibrate(*c.rig.model, c.problem(seed));
    REQUIRE(result.ok);
    const Eigen::VectorXd error =
        result.value - Eigen::Map<const Eigen::VectorXd>(c.truth.data(), 5);
    nees += error.dot(result.covariance.ldlt().solve(error));
  }
  // chi-square with 12 x 5 = 60 degrees of freedom, 95 % two-sided: [40.5, 83.3].
  INFO("NEES over " << kDraws << " draws: " << nees << " (expected 60)");
  CHECK(nees > 40.5);
  CHECK(nees < 83.3);
}

TEST_CASE("calibration fits sensor offsets beside the factors, its sigma honest", "[calibration]") {
  const Commissioning c;
  // The suction transmitter reads 30 kPa high, the outdoor coil's outlet thermistor 0.5 K low.
  const std::vector<double> bias{30e3, 0.0, 0.0, -0.5, 0.0, 0.0};
  Eigen::VectorXd truth(7);
  truth << c.truth[0], c.truth[1], c.truth[2], c.truth[3], c.truth[4], 30e3, -0.5;
  constexpr unsigned kDraws = 10;
  double nees = 0.0;
  for (unsigned seed = 1; seed <= kDraws; ++seed) {
    auto problem = c.problem(seed, bias);
    problem.offset_std = {50e3, 0.0, 0.0, 1.0, 0.0, 0.0};
    const auto result = hvac_twin::est::calibrate(*c.rig.model, problem);
    INFO(result.error);
    REQUIRE(result.ok);
    REQUIRE(result.value.size() == 7);
    const Eigen::VectorXd error = result.value - truth;
    nees += error.dot(result.covariance.ldlt().solve(error));
    if (seed != 1) continue;
    // Without offsets the factors must explain the biased readings: a worse fit.
    problem.offset_std.clear();
    const auto plain = hvac_twin::est::calibrate(*c.rig.model, problem);
    REQUIRE(plain.ok);
    CHECK(result.chi_square < plain.chi_square / 2.0);
    CHECK(result.std[6] < 0.5);  // the windows tell the offset, not only its prior of 1 K
    // A window's fitted reading includes the offset.
    CHECK(std::abs(result.windows.front().fitted[3] -
                   problem.windows.front().y[hp::kCondWallTempOut]) < 1.0);
  }
  // chi-square with 10 x 7 = 70 degrees of freedom, 95 % two-sided: [48.8, 95.0].
  INFO("NEES over " << kDraws << " draws: " << nees << " (expected 70)");
  CHECK(nees > 48.8);
  CHECK(nees < 95.0);
}
