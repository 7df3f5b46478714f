// The built-in models exported as FMI 2.0 Model Exchange FMUs (io/fmi/export) and imported back
// (io/fmi/import) are the same models: the same layout, the same right-hand side, outputs and
// Jacobians, and the same CVODES integration with forward sensitivities.
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <string>
#include <vector>

#include "daemon/estimation/ekf.hpp"
#include "io/fmi/import/fmu_model.hpp"
#include "plant_models/catalog.hpp"
#include "plant_models/core/integrator.hpp"
#include "tests/support/scratch_dir.hpp"
#include "tests/unit/plant_models/heat_pump_fixture.hpp"

using namespace hvac_twin;

namespace {

std::string fmu_path(const std::string& model) {
  return std::string(HVAC_TWIN_BINARY_DIR) + "/fmu/" + model + ".fmu";
}

void check_same_signals(const std::vector<plant::SignalInfo>& a,
                        const std::vector<plant::SignalInfo>& b) {
  REQUIRE(a.size() == b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    INFO(b[i].name);
    CHECK(a[i].name == b[i].name);
    CHECK(a[i].unit == b[i].unit);
    CHECK(a[i].min == b[i].min);
    CHECK(a[i].max == b[i].max);
  }
}

void check_same_layout(const plant::ContinuousModel& fmu, const plant::ContinuousModel& ref) {
  const auto& a = fmu.layout();
  const auto& b = ref.layout();
  REQUIRE(a.states.size() == b.states.size());
  for (std::size_t i = 0; i < a.states.size(); ++i) {
    INFO(b.states[i].name);
    CHECK(a.states[i].name == b.states[i].name);
    CHECK(a.states[i].unit == b.states[i].unit);
    CHECK(a.states[i].min == b.states[i].min);
    CHECK(a.states[i].max == b.states[i].max);
    CHECK(a.states[i].initial == b.states[i].initial);
    CHECK(a.states[i].abs_tol == Approx(b.states[i].abs_tol).epsilon(1e-12));
    // The filter settings the hvac-twin annotations carry (io/fmi/annotations.hpp).
    CHECK(a.states[i].initial_std == b.states[i].initial_std);
    CHECK(a.states[i].process_noise == b.states[i].process_noise);
    CHECK(a.states[i].augmented == b.states[i].augmented);
    CHECK(a.states[i].consider == b.states[i].consider);
    CHECK(a.states[i].calibrate == b.states[i].calibrate);
    CHECK(a.states[i].held_while_settling == b.states[i].held_while_settling);
    CHECK(a.states[i].persistent == b.states[i].persistent);
    CHECK(a.states[i].excited_by == b.states[i].excited_by);
    CHECK(a.states[i].excitation_min == b.states[i].excitation_min);
  }
  check_same_signals(a.inputs, b.inputs);
  check_same_signals(a.outputs, b.outputs);
  for (std::size_t i = 0; i < a.outputs.size(); ++i) {
    CHECK(a.outputs[i].model_error == b.outputs[i].model_error);
    CHECK(a.outputs[i].model_error_rel == b.outputs[i].model_error_rel);
  }
  REQUIRE(a.constraints.size() == b.constraints.size());
  for (std::size_t i = 0; i < a.constraints.size(); ++i) {
    const auto &ca = a.constraints[i], &cb = b.constraints[i];
    INFO(cb.name);
    CHECK(ca.name == cb.name);
    CHECK(ca.over == cb.over);
    CHECK(ca.terms == cb.terms);
    CHECK(ca.bound == cb.bound);
    CHECK(ca.while_input == cb.while_input);
    CHECK(ca.while_above == cb.while_above);
  }
}

// a and b equal to within the heat pump's inner pressure solve: it starts from its last
// solution, so the same model evaluated after another history converges to a slightly different
// point (seen: derivatives 1.3e-9 of the largest apart; outputs and Jacobians to rounding).
void check_close(const std::vector<double>& a, const std::vector<double>& b) {
  REQUIRE(a.size() == b.size());
  double largest = 0.0;
  for (double v : b)
    largest = std::max(largest, std::abs(v));
  double worst = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i)
    worst = std::max(worst, std::abs(a[i] - b[i]));
  const double ratio = worst / largest;
  CAPTURE(ratio);
  CHECK(ratio <= 1e-8);
}

// f, h, J and H of both models at (x, u), entry by entry: the FMU runs the same code.
void check_same_values(const plant::ContinuousModel& fmu, const plant::ContinuousModel& ref,
                       const std::vector<double>& x, const std::vector<double>& u) {
  const std::size_t n = ref.num_states(), m = ref.num_outputs();
  std::vector<double> f1(n), y1(m), j1(n * n), j2(n * n), h1(m * n), h2(m * n);
  REQUIRE(ref.rhs_jacobian(x, u, {}, j2) == plant::kModelOk);
  REQUIRE(fmu.rhs_jacobian(x, u, f1, j1) == plant::kModelOk);
  REQUIRE(ref.output_jacobian(x, u, {}, h2) == plant::kModelOk);
  REQUIRE(fmu.output_jacobian(x, u, y1, h1) == plant::kModelOk);
  check_close(j1, j2);
  check_close(h1, h2);
  // The FMU's values come from the model's plain evaluation, as CVODES's do; the AD evaluation
  // of J may differ from it in the last bits (the heat pump's inner pressure solve).
  std::vector<double> f3(n), y3(m), f4(n), y4(m);
  REQUIRE(ref.rhs(x, u, f4) == plant::kModelOk);
  REQUIRE(ref.outputs(x, u, y4) == plant::kModelOk);
  REQUIRE(fmu.rhs(x, u, f3) == plant::kModelOk);
  REQUIRE(fmu.outputs(x, u, y3) == plant::kModelOk);
  check_close(f1, f4);
  check_close(y1, y4);
  check_close(f3, f4);
  check_close(y3, y4);
}

}  // namespace

TEST_CASE("the zone model exported as an FMU and imported back is the built-in model", "[fmi]") {
  const test::ScratchDir dir("fmu-zone");
  const auto lib = fmi::load_fmu(fmu_path("zone_rc"), dir / "unpacked");
  const fmi::FmuModel fmu(lib, {});
  const auto ref = plant::create_model("zone_rc", {});
  CHECK(fmu.jacobian_method() == fmi::JacobianMethod::kDirectionalDerivative);
  check_same_layout(fmu, *ref);
  for (const auto& [t_air, t_mass, q_int, q_hp, t_out] :
       {std::array{20.0, 20.0, 300.0, 0.0, 0.0}, std::array{26.5, 24.0, 850.0, -4200.0, 33.0},
        std::array{-5.0, 3.0, -100.0, 9000.0, -15.0}})
    check_same_values(fmu, *ref, {t_air, t_mass, q_int}, {q_hp, t_out});

  // A clone is another instance: evaluating one does not disturb the other.
  const auto copy = fmu.clone();
  std::vector<double> f_copy(3), f_fmu(3), f_ref(3);
  REQUIRE(copy->rhs(std::vector{22.0, 21.0, 400.0}, std::vector{-2000.0, 30.0}, f_copy) == 0);
  REQUIRE(fmu.rhs(std::vector{18.0, 19.0, 100.0}, std::vector{1000.0, 5.0}, f_fmu) == 0);
  REQUIRE(ref->rhs(std::vector{22.0, 21.0, 400.0}, std::vector{-2000.0, 30.0}, f_ref) == 0);
  CHECK(f_copy == f_ref);
}

TEST_CASE("a parameter set through the FMU reaches the model", "[fmi]") {
  const test::ScratchDir dir("fmu-param");
  const auto lib = fmi::load_fmu(fmu_path("zone_rc"), dir / "unpacked");
  const plant::ParameterMap params{{"C_air", 8.0e5}, {"UA_air_out", 250.0}};
  const fmi::FmuModel fmu(lib, {.parameters = params});
  const auto ref = plant::create_model("zone_rc", params);
  const auto nominal = plant::create_model("zone_rc", {});
  const std::vector<double> x{24.0, 22.0, 500.0}, u{-3000.0, 31.0};
  check_same_values(fmu, *ref, x, u);
  std::vector<double> f_nominal(3), f_fmu(3);
  REQUIRE(nominal->rhs(x, u, f_nominal) == 0);
  REQUIRE(fmu.rhs(x, u, f_fmu) == 0);
  CHECK(f_fmu[0] != f_nominal[0]);  // negative control: the parameters matter here

  CHECK_THROWS_WITH(fmi::FmuModel(lib, {.parameters = {{"C_airr", 1e6}}}),
                    Catch::Contains("\"C_airr\" is not a Real parameter"));
  CHECK_THROWS_WITH(fmi::FmuModel(lib, {.parameters = {{"C_air", -1.0}}}),
                    Catch::Contains("\"C_air\"") && Catch::Contains("outside its range"));
}

TEST_CASE("the heat pump exported as an FMU integrates as the built-in model does",
          "[fmi][heat_pump]") {
  const test::ScratchDir dir("fmu-heat-pump");
  const auto lib = fmi::load_fmu(fmu_path("heat_pump_r32"), dir / "unpacked");
  const fmi::FmuModel fmu(lib, {});
  const test::HeatPumpRig rig(test::demo_structure());
  const auto& ref = *rig.model;
  check_same_layout(fmu, ref);
  const auto u = test::nominal_inputs();
  auto x = rig.start();
  rig.run(x, u, 300.0);  // an operating point with the cycle running
  check_same_values(fmu, ref, x, u);

  // CVODES with forward sensitivities over one 5 s period, on each model: the same state and
  // the same state-transition matrix (the tolerances agree to rounding: the FMU's nominal values
  // carry the model's absolute tolerances).
  plant::IntegratorOptions opt;
  opt.sensitivities = true;
  const std::size_t n = ref.num_states();
  auto x_ref = x, x_fmu = x;
  std::vector<double> F_ref(n * n), F_fmu(n * n);
  plant::Integrator integ_ref(ref, opt), integ_fmu(fmu, opt);
  REQUIRE(integ_ref.step(x_ref, u, 5.0, F_ref).ok());
  REQUIRE(integ_fmu.step(x_fmu, u, 5.0, F_fmu).ok());
  double dx = 0.0, dF = 0.0, moved = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const double scale = ref.layout().states[i].abs_tol;
    dx = std::max(dx, std::abs(x_fmu[i] - x_ref[i]) / scale);
    moved = std::max(moved, std::abs(x_ref[i] - x[i]) / scale);
  }
  for (std::size_t k = 0; k < n * n; ++k)
    dF = std::max(dF, std::abs(F_fmu[k] - F_ref[k]));
  INFO("state difference " << dx << " absolute tolerances (moved " << moved << "), F " << dF);
  CHECK(moved > 1e3);  // the period is not trivial
  CHECK(dx < 1.0);
  CHECK(dF < 1e-6);
}

TEST_CASE("central differences on the FMU agree with its directional derivatives", "[fmi]") {
  const test::ScratchDir dir("fmu-fd");
  const auto lib = fmi::load_fmu(fmu_path("heat_pump_r32"), dir / "unpacked");
  const fmi::FmuModel exact(lib, {});
  const fmi::FmuModel fd(lib, {.finite_differences = true});
  CHECK(fd.jacobian_method() == fmi::JacobianMethod::kFiniteDifferences);
  const test::HeatPumpRig rig(test::demo_structure());
  const auto u = test::nominal_inputs();
  auto x = rig.start();
  rig.run(x, u, 300.0);
  const std::size_t n = exact.num_states(), m = exact.num_outputs();
  for (const bool outputs : {false, true}) {
    const std::size_t rows = outputs ? m : n;
    std::vector<double> a(rows * n), b(rows * n);
    if (outputs) {
      REQUIRE(exact.output_jacobian(x, u, {}, a) == 0);
      REQUIRE(fd.output_jacobian(x, u, {}, b) == 0);
    } else {
      REQUIRE(exact.rhs_jacobian(x, u, {}, a) == 0);
      REQUIRE(fd.rhs_jacobian(x, u, {}, b) == 0);
    }
    // Each entry against the largest of its row (the columns' scales differ by orders).
    double worst = 0.0;
    for (std::size_t r = 0; r < rows; ++r) {
      double row_max = 1e-300;
      for (std::size_t c = 0; c < n; ++c)
        row_max = std::max(row_max, std::abs(a[c * rows + r]));
      for (std::size_t c = 0; c < n; ++c)
        worst = std::max(worst, std::abs(a[c * rows + r] - b[c * rows + r]) / row_max);
    }
    INFO((outputs ? "H" : "J") << ": worst entry error " << worst << " of its row's largest");
    CHECK(worst < 1e-4);
  }
}

TEST_CASE("an input disturbance of an FMU is a random-walk state added to its input", "[fmi]") {
  const test::ScratchDir dir("fmu-disturbance");
  const auto lib = fmi::load_fmu(fmu_path("zone_rc"), dir / "unpacked");
  const auto ref = plant::create_model("zone_rc", {});
  for (const bool fd : {false, true}) {
    INFO((fd ? "central differences" : "directional derivatives"));
    const fmi::FmuModel fmu(
        lib, {.parameters = {{"augment_heat_pump_heat", 1.0}}, .finite_differences = fd});
    const auto& states = fmu.layout().states;
    REQUIRE(states.size() == 4);
    CHECK(states[3].name == "heat_pump_heat_disturbance");
    CHECK(states[3].unit == "W");
    CHECK(states[3].augmented);
    CHECK(states[3].initial == 0.0);

    const std::vector<double> x{24.0, 22.0, 500.0, -800.0}, u{-3000.0, 31.0};
    const std::vector<double> x_ref{24.0, 22.0, 500.0}, u_moved{-3800.0, 31.0};
    std::vector<double> f(4), f_ref(3), y(4), y_ref(4), J(16), H(16);
    REQUIRE(fmu.rhs_jacobian(x, u, f, J) == 0);
    REQUIRE(fmu.output_jacobian(x, u, y, H) == 0);
    REQUIRE(ref->rhs(x_ref, u_moved, f_ref) == 0);
    REQUIRE(ref->outputs(x_ref, u_moved, y_ref) == 0);
    for (std::size_t i = 0; i < 3; ++i)
      CHECK(f[i] == f_ref[i]);
    CHECK(f[3] == 0.0);
    CHECK(y == y_ref);
    // The disturbance's column: d f / d heat_pump_heat, hp_fraction_air / C_air for the air
    // (1 / 2e6 per W) and nothing for the mass and the gains; its row: zero (d' = 0).
    CHECK(J[3 * 4 + 0] == Approx(1.0 / 2.0e6).epsilon(1e-6));
    CHECK(std::abs(J[3 * 4 + 1]) < 1e-15);
    CHECK(J[3 * 4 + 2] == 0.0);
    for (std::size_t c = 0; c < 4; ++c)
      CHECK(J[c * 4 + 3] == 0.0);
  }
  CHECK_THROWS_WITH(fmi::FmuModel(lib, {.parameters = {{"augment_heat_pump_heat", 2.0}}}),
                    Catch::Contains("\"augment_heat_pump_heat\" is not 0 or 1"));
  CHECK_THROWS_WITH(fmi::FmuModel(lib, {.parameters = {{"augment_T_air", 1.0}}}),
                    Catch::Contains("\"augment_T_air\" is not 0 or 1 for an input"));
}

TEST_CASE("the constrained EKF on the heat-pump FMU gives the built-in model's estimates",
          "[fmi][heat_pump]") {
  // Both filters from the same guess, fed the same seven measurements of a run 20 minutes ahead
  // of it for 30 periods of 5 s: the states and the published sigmas agree. (The daemon's start
  // differs: the built-in model guesses a consistent state from the measured conditions, an FMU
  // cannot; here both start from the same state.)
  const test::ScratchDir dir("fmu-ekf");
  const auto lib = fmi::load_fmu(fmu_path("heat_pump_r32"), dir / "unpacked");
  const fmi::FmuModel fmu(lib, {});
  const test::HeatPumpRig rig(test::demo_structure());
  const auto u = test::nominal_inputs();
  const auto guess = rig.start();
  auto truth = guess;
  rig.run(truth, u, 1200.0);
  const auto& layout = rig.model->layout();
  std::vector<double> q, s0;
  for (const auto& s : layout.states) {
    q.push_back(s.process_noise);
    s0.push_back(s.initial_std);
  }
  est::EkfOptions options;
  options.constrained = true;
  est::Ekf builtin(*rig.model, q, 7, options), through_fmu(fmu, q, 7, options);
  builtin.reset(guess, s0);
  through_fmu.reset(guess, s0);
  const std::vector<double> sigma{5e3, 15e3, 0.2, 0.2, 0.2, 0.2, 0.05};
  const std::size_t n = layout.states.size(), m = layout.outputs.size();
  double worst_x = 0.0, worst_sigma = 0.0, moved = 0.0;
  for (int k = 0; k < 30; ++k) {
    rig.run(truth, u, 5.0, 5.0);
    const auto y = rig.outputs(truth, u);
    std::vector<est::Measurement> z;
    for (std::size_t i = 0; i < sigma.size(); ++i)  // the first seven outputs are the sensors
      z.push_back({i, y[i], sigma[i] * sigma[i], true});
    std::vector<est::MeasurementReport> r1(z.size()), r2(z.size());
    REQUIRE(builtin.predict(u, 5.0) == through_fmu.predict(u, 5.0));
    REQUIRE(builtin.update(z, u, r1) == through_fmu.update(z, u, r2));
    std::vector<double> y1(m), y2(m), sd1(m), sd2(m);
    REQUIRE(builtin.filter_output_estimates(u, y1, sd1) == 0);
    REQUIRE(through_fmu.filter_output_estimates(u, y2, sd2) == 0);
    for (std::size_t i = 0; i < n; ++i) {
      const auto j = static_cast<Eigen::Index>(i);
      worst_x = std::max(worst_x, std::abs(builtin.state()(j) - through_fmu.state()(j)) / s0[i]);
      moved = std::max(moved, std::abs(builtin.state()(j) - guess[i]) / s0[i]);
    }
    for (std::size_t i = 0; i < m; ++i)
      worst_sigma = std::max(worst_sigma, std::abs(sd1[i] - sd2[i]) / std::max(sd1[i], 1e-300));
  }
  INFO("largest state difference " << worst_x << " initial sigmas (the filter moved " << moved
                                   << "), largest output sigma difference " << worst_sigma
                                   << " of itself");
  // Agreement to round-off, amplified: the FMU evaluates the model in its own order, so each
  // pressure solve starts from another warm start and ends another round-off (1e-15) away, and
  // 30 gated, constrained updates magnify that. Measured: 1.7e-7 / 3.7e-7 (states / sigmas)
  // with a zero-order warm start, 5.7e-7 / 1.3e-6 with the first-order one (stop 53); a
  // mismatch that is not round-off, the FMU's import ignoring the states' Jacobian-reuse unit,
  // 0.023 / 0.031.
  CHECK(moved > 0.1);
  CHECK(worst_x < 1e-5);
  CHECK(worst_sigma < 1e-5);
}
