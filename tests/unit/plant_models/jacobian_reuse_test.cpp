// Jacobian reuse across periods (IntegratorOptions::jacobian_reuse_sigma with the exponential F):
// the integrator keeps one model Jacobian, and the matrix exponential made of it, from one step()
// to the next while no state has moved beyond the reuse distance (in units of its reuse_scale,
// else its initial_std) and no input beyond it in units of its reuse_scale; it evaluates them
// afresh when an input moves further, and never keeps them at a distance of 0. On the settled
// heat pump, where a unit in steady operation spends its time.
#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "tests/support/transition_distance.hpp"
#include "tests/unit/plant_models/heat_pump_fixture.hpp"

using namespace hvac_twin;
using plant::HeatPumpR32;
using plant::Integrator;
using plant::IntegratorOptions;
using plant::SensitivityMethod;

namespace {

IntegratorOptions exponential(double reuse) {
  IntegratorOptions o;
  o.rel_tol = 1e-5;  // the filters' (est::filter_integrator_options)
  o.abs_tol_scale = 10.0;
  o.sensitivities = true;
  o.sensitivity_method = SensitivityMethod::kExponential;
  o.jacobian_reuse_sigma = reuse;
  return o;
}

}  // namespace

TEST_CASE("settled heat pump: one Jacobian and one exponential serve period after period",
          "[integrator][expm][reuse]") {
  const test::HeatPumpRig rig(test::demo_structure());
  std::vector<double> x = rig.start();
  std::vector<double> u = test::nominal_inputs();
  rig.run(x, u, 3600.0);
  const std::size_t n = x.size();
  std::vector<double> scale;
  for (const auto& s : rig.model->layout().states)
    scale.push_back(s.abs_tol / 1e-5);
  // A reference at every period's own state: no reuse at all.
  Integrator fresh(*rig.model, exponential(0.0));
  Integrator reused(*rig.model, exponential(0.05));
  std::vector<double> F(n * n), F_first(n * n), F_fresh(n * n);

  std::vector<double> xr = x;
  REQUIRE(reused.step(xr, u, 1.0, F_first).ok());
  CHECK(reused.last_stats().model_jacobians >= 1);
  CHECK(reused.last_stats().exponentials == 1);

  // The next periods from where the last ended, an input moved by a fifth of its reuse distance
  // (outdoor air: reuse_scale 2 K, so 0.1 K at 0.05): nothing evaluated again, F the same.
  for (int k = 0; k < 3; ++k) {
    u[plant::hp::kOutdoorTemperature] += 0.02 * (k == 1);
    std::vector<double> xf = xr;
    REQUIRE(fresh.step(xf, u, 1.0, F_fresh).ok());
    REQUIRE(reused.step(xr, u, 1.0, F).ok());
    INFO("period " << k);
    CHECK(reused.last_stats().model_jacobians == 0);
    CHECK(reused.last_stats().exponentials == 0);
    CHECK(F == F_first);
    CHECK(fresh.last_stats().model_jacobians >= 1);
    // As accurate as the reuse within a period (sensitivity_test: F within 0.1 x its 0.1).
    CHECK(test::transition_error(F, F_fresh, scale).relative < 1e-2);
    for (std::size_t i = 0; i < n; ++i)
      CHECK(xr[i] == Approx(xf[i]).epsilon(1e-6).margin(rig.model->layout().states[i].abs_tol));
  }

  SECTION("an input moved beyond its reuse distance: evaluated afresh") {
    u[plant::hp::kOutdoorTemperature] += 0.5;  // 0.1 K allowed
    REQUIRE(reused.step(xr, u, 1.0, F).ok());
    CHECK(reused.last_stats().model_jacobians >= 1);
    CHECK(reused.last_stats().exponentials == 1);
  }
  SECTION("another period length: the Jacobian kept, its exponential computed again") {
    REQUIRE(reused.step(xr, u, 2.0, F).ok());
    CHECK(reused.last_stats().model_jacobians == 0);
    CHECK(reused.last_stats().exponentials == 1);
  }
  SECTION("at a reuse distance of 0 every period evaluates its own") {
    std::vector<double> xf = xr;
    REQUIRE(fresh.step(xf, u, 1.0, F).ok());
    CHECK(fresh.last_stats().model_jacobians >= 1);
    CHECK(fresh.last_stats().exponentials >= 1);
  }
}

TEST_CASE("states the Jacobian barely depends on: their moves alone keep the Jacobian",
          "[integrator][reuse]") {
  // The layout widens the reuse unit of a state only where the claim holds: at the settled
  // nominal point, a move of 2 initial sigma of such a state changes the model's Jacobian (in
  // the states' own units, D^-1 J D with D their initial sigmas) by less than 1e-4 of itself,
  // while a 0.1-sigma move of an evaporator cell's enthalpy, which the reuse distance is made
  // for, changes it by more than 1e-3.
  const test::HeatPumpRig rig(test::demo_structure());
  std::vector<double> x = rig.start();
  const std::vector<double> u = test::nominal_inputs();
  rig.run(x, u, 3600.0);
  const auto& states = rig.model->layout().states;
  const std::size_t n = x.size();
  std::vector<double> f(n), J0(n * n), J1(n * n);
  REQUIRE(rig.model->rhs_jacobian(x, u, f, J0) == plant::kModelOk);
  const auto change = [&](std::size_t i, double sigmas) {
    std::vector<double> xp = x;
    xp[i] += sigmas * states[i].initial_std;
    REQUIRE(rig.model->rhs_jacobian(xp, u, f, J1) == plant::kModelOk);
    double d = 0.0, b = 0.0;
    for (std::size_t c = 0; c < n; ++c)
      for (std::size_t r = 0; r < n; ++r) {
        const double w = states[c].initial_std / states[r].initial_std;
        d += std::pow(w * (J1[c * n + r] - J0[c * n + r]), 2);
        b += std::pow(w * J0[c * n + r], 2);
      }
    return std::sqrt(d / b);
  };
  int widened = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!(states[i].reuse_scale > states[i].initial_std)) continue;
    ++widened;
    INFO(states[i].name);
    CHECK(change(i, 2.0) < 1e-4);
  }
  CHECK(widened == 4);  // the zone's temperatures, its gains, the leak rate
  const auto& l = rig.hp->slots();
  CHECK(change(l.h_evap[l.h_evap.size - 2], 0.1) > 1e-3);
}
