// How fast the R32 heat-pump model simulates, and what the phase-boundary smoothing buys.
//
//   heat_pump_bench [--short] [--cells N]
//
// 1. Simulation speed: a day (2 h with --short) of operation at N cells per heat exchanger
//    (default 12, the model's) with the compressor speed, valve, fans and outdoor temperature
//    changing every 15 minutes, integrated with the same integrator and tolerances as the
//    simulator; prints simulated seconds per wall second and the integrator's work.
// 2. Smoothing: the same day on the raw table for the line cells (drho/dh jumping at the
//    saturation lines): steps, error-test and convergence failures.
// 3. The cost of one right-hand side (a new pressure solve each time) and of one exact Jacobian
//    at the nominal point, and their ratio.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "plant_models/catalog.hpp"
#include "plant_models/core/ad_model.hpp"
#include "plant_models/core/integrator.hpp"
#include "plant_models/heat_pump/heat_pump.hpp"

using namespace hvac_twin::plant;

namespace {

struct Run {
  double wall_s = 0.0;
  long steps = 0, rhs = 0, jac = 0, err_fails = 0, conv_fails = 0;
  bool ok = true;
};

Run simulate(int cells, double smoothing, double hours) {
  const auto model =
      create_model("heat_pump_r32", {{"cells", cells}, {"smoothing_width", smoothing}});
  const auto& hp = dynamic_cast<const AdModel<HeatPumpR32>&>(*model).model();
  std::vector<double> x = hp.initial_state(32.0, 26.0, hp.params().nameplate_charge);
  Integrator integ(*model, IntegratorOptions{});
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  Run r;
  const auto t0 = std::chrono::steady_clock::now();
  const int periods = static_cast<int>(hours * 4.0);
  for (int k = 0; k < periods && r.ok; ++k) {
    const std::vector<double> u{30.0 + 50.0 * U(rng), 0.30 + 0.10 * U(rng), 0.6 + 0.5 * U(rng),
                                0.6 + 0.5 * U(rng), 24.0 + 14.0 * U(rng)};
    // The daemon's view: one integrator call per 10 s period.
    for (int j = 0; j < 90 && r.ok; ++j) {
      r.ok = integ.step(x, u, 10.0, {}).ok();
      const auto& s = integ.last_stats();
      r.steps += s.steps;
      r.rhs += s.rhs_evals;
      r.jac += s.jac_evals;
      r.err_fails += s.error_test_failures;
      r.conv_fails += s.nonlinear_failures;
    }
  }
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

// Microseconds per right-hand side (each at a slightly different state, so the pressure solve
// is not cached) and per AD Jacobian, at the nominal point after 10 minutes.
std::pair<double, double> costs(int cells) {
  const auto model = create_model("heat_pump_r32", {{"cells", cells}, {"augment_fouling", 1}});
  const auto& hp = dynamic_cast<const AdModel<HeatPumpR32>&>(*model).model();
  std::vector<double> x = hp.initial_state(35.0, 27.0, hp.params().nameplate_charge);
  const std::vector<double> u{50.0, 0.374, 1.0, 1.0, 35.0};
  Integrator(*model, IntegratorOptions{}).step(x, u, 600.0, {});
  const std::size_t n = x.size();
  std::vector<double> f(n), jac(n * n);
  const auto time = [&](int reps, auto&& call) {
    const auto t0 = std::chrono::steady_clock::now();
    for (int i = 0; i < reps; ++i) {
      x[hp.slots().h_cond[0]] += 1e-9;
      call();
    }
    return std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0)
               .count() /
           reps;
  };
  const double rhs = time(2000, [&] { model->rhs(x, u, f); });
  const double jacobian = time(500, [&] { model->rhs_jacobian(x, u, f, jac); });
  return {rhs, jacobian};
}

void print(const char* label, const Run& r, double hours) {
  std::printf(
      "  %-28s %8.2f s wall  %8.0fx real time  steps %7ld  rhs %8ld  jac %6ld  "
      "error-test fails %5ld  convergence fails %5ld%s\n",
      label, r.wall_s, hours * 3600.0 / r.wall_s, r.steps, r.rhs, r.jac, r.err_fails, r.conv_fails,
      r.ok ? "" : "  (FAILED)");
}

}  // namespace

int main(int argc, char** argv) {
  bool short_mode = false;
  int cells = 12;  // the default (hp_params.hpp)
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--short") == 0) {
      short_mode = true;
    } else if (std::strcmp(argv[i], "--cells") == 0 && i + 1 < argc) {
      cells = std::atoi(argv[++i]);
    } else {
      std::fprintf(stderr, "usage: heat_pump_bench [--short] [--cells N]\n");
      return 2;
    }
  }
  const double hours = short_mode ? 2.0 : 24.0;
  std::printf(
      "heat_pump_r32, N = %d cells per heat exchanger, %.0f simulated hours, inputs "
      "changing every 15 min, one integrator call per 10 s (rtol 1e-6)\n",
      cells, hours);
  const Run smooth = simulate(cells, 300.0, hours);
  print("smoothing 300 J/kg (default)", smooth, hours);
  const Run sharp = simulate(cells, 0.0, hours);
  print("no smoothing (raw table)", sharp, hours);
  const auto [rhs_us, jac_us] = costs(cells);
  std::printf("  one right-hand side %.1f us, one exact Jacobian %.1f us (%.1f right-hand sides)\n",
              rhs_us, jac_us, jac_us / rhs_us);
  const bool pass = smooth.ok && smooth.wall_s < hours * 3600.0;
  std::printf("%s: %.0fx faster than real time\n", pass ? "PASS" : "FAIL",
              hours * 3600.0 / smooth.wall_s);
  return pass ? 0 : 1;
}
