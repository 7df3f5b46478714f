// The integrator's state-transition matrix F by the direct per-step sensitivity solve (the
// default) against CVODES's own staggered corrector: the same F, exact to the integrator's
// tolerance against a tight reference, one model Jacobian per distinct state, recovery from model
// errors inside the solve. The heat-pump case uses the model through ContinuousModel only.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "plant_models/catalog.hpp"
#include "plant_models/core/ad_model.hpp"
#include "plant_models/core/integrator.hpp"
#include "tests/support/transition_distance.hpp"

using namespace hvac_twin::plant;

namespace {

// Robertson's stiff kinetics (as in integrator_test.cpp).
struct Robertson {
  ModelLayout layout() const {
    ModelLayout l;
    for (std::string name : {"y1", "y2", "y3"})
      l.states.push_back(StateInfo{.name = name, .unit = "1", .abs_tol = 1e-10});
    return l;
  }
  template <class S>
  int rhs(std::span<const S> x, std::span<const double>, std::span<S> f) const {
    f[0] = -0.04 * x[0] + 1e4 * x[1] * x[2];
    f[2] = 3e7 * x[1] * x[1];
    f[1] = -f[0] - f[2];
    return kModelOk;
  }
  template <class S>
  int outputs(std::span<const S>, std::span<const double>, std::span<S>) const {
    return kModelOk;
  }
};

// x' = -x whose second and third Jacobian evaluations (Dual scalars) fail recoverably: the
// Newton matrix's or the direct sensitivity solve's, after the one at t = 0.
struct Flaky {
  mutable int jacobian_calls = 0;
  ModelLayout layout() const {
    ModelLayout l;
    l.states.push_back(StateInfo{.name = "x", .unit = "1", .abs_tol = 1e-12});
    return l;
  }
  template <class S>
  int rhs(std::span<const S> x, std::span<const double>, std::span<S> f) const {
    if constexpr (!std::is_same_v<S, double>) {
      ++jacobian_calls;
      if (jacobian_calls == 2 || jacobian_calls == 3) return kModelRecoverable;
    }
    f[0] = -x[0];
    return kModelOk;
  }
  template <class S>
  int outputs(std::span<const S>, std::span<const double>, std::span<S>) const {
    return kModelOk;
  }
};

// x' = A x, A = [[-2, 1], [0, -0.5]]: its Jacobian is the same everywhere.
struct Linear {
  ModelLayout layout() const {
    ModelLayout l;
    for (std::string name : {"a", "b"})
      l.states.push_back(
          StateInfo{.name = name, .unit = "1", .initial_std = 1.0, .abs_tol = 1e-12});
    return l;
  }
  template <class S>
  int rhs(std::span<const S> x, std::span<const double>, std::span<S> f) const {
    f[0] = -2.0 * x[0] + x[1];
    f[1] = -0.5 * x[1];
    return kModelOk;
  }
  template <class S>
  int outputs(std::span<const S>, std::span<const double>, std::span<S>) const {
    return kModelOk;
  }
};

IntegratorOptions sensitivities(SensitivityMethod method, double rel_tol, bool error_control) {
  IntegratorOptions o;
  o.sensitivities = true;
  o.sensitivity_method = method;
  o.rel_tol = rel_tol;
  o.sensitivity_error_control = error_control;
  return o;
}

// Relative Frobenius distance of D^-1 F D from D^-1 R D, D = diag(scale).
double distance(const std::vector<double>& F, const std::vector<double>& R,
                const std::vector<double>& scale) {
  return hvac_twin::test::transition_error(F, R, scale).relative;
}

// The heat pump (10 cells, fouling augmented) 1.5 s into a speed and valve step from a settled
// state, the inputs back at their old values: the next 5 s are a transient. F_ref is its F over
// those 5 s at a tight tolerance; scale the states' resolution scales.
struct HeatPumpTransient {
  std::unique_ptr<ContinuousModel> model =
      create_model("heat_pump_r32", ParameterMap{{"cells", 10}, {"augment_fouling", 1}});
  std::vector<double> x, u, scale, F_ref;
  bool ok = false;

  HeatPumpTransient() {
    const ModelLayout& L = model->layout();
    const std::size_t n = model->num_states();
    u.assign(model->num_inputs(), 1.0);
    u[*L.input("compressor_speed")] = 50.0;
    u[*L.input("valve_opening")] = 0.355;
    u[*L.input("outdoor_temperature")] = 35.0;
    std::vector<double> y(model->num_outputs(), std::nan(""));
    x.resize(n);
    model->initial_guess(u, y, x);
    Integrator settle(*model, IntegratorOptions{});
    std::vector<double> u2 = u;
    u2[*L.input("compressor_speed")] = 62.0;
    u2[*L.input("valve_opening")] = 0.38;
    for (const auto& s : L.states)
      scale.push_back(s.abs_tol / 1e-6);
    IntegratorOptions tight = sensitivities(SensitivityMethod::kCvodesNewton, 1e-10, true);
    tight.abs_tol_scale = 1e-4;
    F_ref.resize(n * n);
    std::vector<double> xs;
    ok = settle.step(x, u, 600.0, {}).ok() && settle.step(x, u2, 1.5, {}).ok() &&
         Integrator(*model, tight).step(xs = x, u, 5.0, F_ref).ok();
  }
};

}  // namespace

TEST_CASE("direct sensitivities equal CVODES's corrector on a stiff problem", "[integrator]") {
  const AdModel<Robertson> model{Robertson{}};
  const std::vector<double> x0{0.98, 0.0, 0.02}, scale{1.0, 1e-4, 1.0};
  std::vector<double> F_direct(9), F_newton(9);
  for (const bool errcon : {false, true}) {
    Integrator direct(model, sensitivities(SensitivityMethod::kDirect, 1e-10, errcon));
    Integrator newton(model, sensitivities(SensitivityMethod::kCvodesNewton, 1e-10, errcon));
    std::vector<double> xd = x0, xn = x0;
    REQUIRE(direct.step(xd, {}, 40.0, F_direct).ok());
    REQUIRE(newton.step(xn, {}, 40.0, F_newton).ok());
    INFO("error control " << errcon);
    CHECK(distance(F_direct, F_newton, scale) < 1e-7);
    CHECK(xd[0] == Approx(xn[0]).epsilon(1e-8));
    // One direct solve per accepted step, one model Jacobian per distinct state.
    const IntegrationStats& s = direct.last_stats();
    CHECK(s.sens_solves >= s.steps);
    CHECK(s.model_jacobians <= s.sens_solves + s.jac_evals + 1);
    // CVODES's corrector asks for J S several times per step, at one state: served once.
    const IntegrationStats& t = newton.last_stats();
    CHECK(t.model_jacobians < t.sens_rhs_evals);
    CHECK(t.jacobian_reuses > 0);
  }
}

TEST_CASE("a recoverable model error inside the direct sensitivity solve shortens the step",
          "[integrator]") {
  const AdModel<Flaky> model{Flaky{}};
  Integrator integ(model, sensitivities(SensitivityMethod::kDirect, 1e-8, false));
  std::vector<double> x{2.0}, F(1);
  REQUIRE(integ.step(x, {}, 1.0, F).ok());
  CHECK(x[0] == Approx(2.0 * std::exp(-1.0)).epsilon(1e-6));
  CHECK(F[0] == Approx(std::exp(-1.0)).epsilon(1e-6));
}

TEST_CASE("heat pump: F by the direct solve is exact to the integrator's tolerance",
          "[integrator][heat_pump]") {
  const HeatPumpTransient hp;
  REQUIRE(hp.ok);
  const ContinuousModel* model = hp.model.get();
  const std::vector<double>&x = hp.x, &u = hp.u, &scale = hp.scale, &F_ref = hp.F_ref;
  const std::size_t n = model->num_states();
  std::vector<double> F(n * n), F_newton(n * n), xs;

  // Under sensitivity error control F converges with the tolerance.
  for (const double rel_tol : {1e-6, 1e-8}) {
    IntegratorOptions o = sensitivities(SensitivityMethod::kDirect, rel_tol, true);
    o.abs_tol_scale = 1e-4;
    Integrator integ(*model, o);
    xs = x;
    REQUIRE(integ.step(xs, u, 5.0, F).ok());
    INFO("rel_tol " << rel_tol);
    CHECK(distance(F, F_ref, scale) < 20.0 * rel_tol);
  }
  // Default options: the direct solve and CVODES's corrector give the same F (both ride on the
  // state's steps), within about 1e-3 of the reference on this transient.
  Integrator direct(*model, sensitivities(SensitivityMethod::kDirect, 1e-6, false));
  Integrator newton(*model, sensitivities(SensitivityMethod::kCvodesNewton, 1e-6, false));
  xs = x;
  REQUIRE(direct.step(xs, u, 5.0, F).ok());
  xs = x;
  REQUIRE(newton.step(xs, u, 5.0, F_newton).ok());
  CHECK(distance(F, F_ref, scale) < 5e-3);
  CHECK(distance(F_newton, F_ref, scale) < 5e-3);
  CHECK(distance(F, F_newton, scale) < 5e-3);
  CHECK(direct.last_stats().model_jacobians <= direct.last_stats().steps + 5);
}

TEST_CASE("a linear model's F is exact with one Jacobian reused for every step", "[integrator]") {
  // Reusing the Jacobian loses nothing; a distance no state moves beyond leaves one model
  // Jacobian per call, where the exact default takes one per step.
  const AdModel<Linear> model{Linear{}};
  IntegratorOptions o = sensitivities(SensitivityMethod::kDirect, 1e-9, true);
  Integrator exact(model, o);
  o.jacobian_reuse_sigma = 1e9;
  Integrator reused(model, o);
  std::vector<double> xe{1.0, 1.0}, xr{1.0, 1.0}, Fe(4), Fr(4);
  REQUIRE(exact.step(xe, {}, 3.0, Fe).ok());
  REQUIRE(reused.step(xr, {}, 3.0, Fr).ok());
  // exp(A t) of the upper-triangular A: e^{-2t}, (e^{-t/2} - e^{-2t}) / 1.5, 0, e^{-t/2}.
  const double t = 3.0, e2 = std::exp(-2.0 * t), e05 = std::exp(-0.5 * t);
  const std::vector<double> want{e2, 0.0, (e05 - e2) / 1.5, e05};  // column-major
  for (std::size_t i = 0; i < 4; ++i) {
    CHECK(Fr[i] == Approx(want[i]).margin(1e-6));
    CHECK(Fe[i] == Approx(want[i]).margin(1e-6));
  }
  CHECK(reused.last_stats().model_jacobians == 1);
  CHECK(exact.last_stats().model_jacobians > 10);
}

TEST_CASE("heat pump: a Jacobian reused within 0.05 sigma keeps F within its tolerance",
          "[integrator][heat_pump]") {
  const HeatPumpTransient hp;
  REQUIRE(hp.ok);
  const std::size_t n = hp.model->num_states();
  std::vector<double> F(n * n), xs;

  // The filters' settings: F under error control at a relative tolerance of 0.1.
  IntegratorOptions o = sensitivities(SensitivityMethod::kDirect, 1e-6, true);
  o.sensitivity_rel_tol = 0.1;
  long jacobians[2] = {0, 0};
  double error[2] = {0.0, 0.0};
  for (const int reuse : {0, 1}) {
    o.jacobian_reuse_sigma = reuse ? 0.05 : 0.0;
    Integrator integ(*hp.model, o);
    xs = hp.x;
    REQUIRE(integ.step(xs, hp.u, 5.0, F).ok());
    jacobians[reuse] = integ.last_stats().model_jacobians;
    error[reuse] = distance(F, hp.F_ref, hp.scale);
  }
  INFO("Jacobians exact " << jacobians[0] << ", reused " << jacobians[1] << "; F error exact "
                          << error[0] << ", reused " << error[1]);
  CHECK(jacobians[1] < jacobians[0]);
  CHECK(error[1] < 0.1 * 0.1);  // well inside F's own relative tolerance
  CHECK(error[1] < 5.0 * error[0] + 1e-3);
}
