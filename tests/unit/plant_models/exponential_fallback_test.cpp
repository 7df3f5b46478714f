// The exponential F's fallback (plant::Integrator::step, kExponential): at a state whose
// linearisation grows faster than a double can carry over one segment (stiff_state.hpp), the
// period is integrated again with F by CVODES's own sensitivities.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "tests/support/transition_distance.hpp"
#include "tests/unit/plant_models/heat_pump_fixture.hpp"
#include "tests/unit/plant_models/stiff_state.hpp"

using namespace hvac_twin;
using plant::Integrator;
using plant::IntegratorOptions;
using plant::SensitivityMethod;

namespace {

// The filters' integrator (est::filter_integrator_options) with the given F method.
IntegratorOptions filter_options(SensitivityMethod method) {
  IntegratorOptions o;
  o.rel_tol = 1e-5;
  o.abs_tol_scale = 10.0;
  o.max_steps = 1000;
  o.sensitivities = true;
  o.sensitivity_error_control = true;
  o.sensitivity_rel_tol = 0.1;
  o.jacobian_reuse_sigma = 0.1;
  o.sensitivity_method = method;
  return o;
}

}  // namespace

TEST_CASE("an exponential that overflows: the period's F by CVODES's sensitivities instead",
          "[integrator][expm]") {
  const test::HeatPumpRig rig(test::stiff_structure());
  REQUIRE(rig.model->num_states() == test::kStiffState.size());
  const std::size_t n = test::kStiffState.size();
  Integrator exponential(*rig.model, filter_options(SensitivityMethod::kExponential));
  std::vector<double> x = test::kStiffState, F(n * n, 0.0);
  const auto r = exponential.step(x, test::kStiffInputs, 5.0, F);
  INFO(exponential.last_error());
  REQUIRE(r.ok());
  CHECK(exponential.fallbacks() == 1);  // without the fallback: flag -8, no matrix exponential
  // The period as CVODES's corrector integrates it from a fresh start (not to the bit: the
  // model's pressure solve starts from its last solution, so evaluations depend on history).
  Integrator cvodes(*rig.model, filter_options(SensitivityMethod::kCvodesNewton));
  std::vector<double> x_ref = test::kStiffState, F_ref(n * n, 0.0), scale;
  REQUIRE(cvodes.step(x_ref, test::kStiffInputs, 5.0, F_ref).ok());
  for (const auto& s : rig.model->layout().states)
    scale.push_back(s.abs_tol / 1e-5);
  double worst_x = 0.0;
  for (std::size_t i = 0; i < n; ++i)
    worst_x = std::max(worst_x, std::abs(x[i] - x_ref[i]) / scale[i]);
  const auto e = test::transition_error(F, F_ref, scale);
  // Measured: 1.3e-5 and 7.9e-6 (the exponentials, where they hold, are within 1e-2).
  CHECK(worst_x < 1e-3);
  CHECK(e.relative < 1e-3);
  bool finite = true;
  for (const double f : F)
    finite = finite && std::isfinite(f);
  CHECK(finite);
}
