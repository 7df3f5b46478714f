// Replays one prediction of the leak benchmark's filter alone, from a failure dump
// (leak_bench --trace-dir DIR writes DIR/leak_bench_X_failures.txt): the state and inputs
// before the failed prediction. Prints CVODES's verdict with and without sensitivities, how far
// the state integrates in sub-periods, the outputs along the way and the states at or near their
// bounds where it stops. A dump of the truth's failed integration (its header says "truth")
// replays the truth's model (TruthKind::kNominal) at the truth's tolerance.
//
//   predict_replay FILE [--index K] [--period S]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "daemon/estimation/estimator.hpp"
#include "plant_models/catalog.hpp"
#include "plant_models/core/integrator.hpp"
#include "tests/bench/heat_pump_scenario.hpp"

using namespace hvac_twin;

namespace {

struct Dump {
  std::string header;
  std::vector<double> x, u;
};

std::vector<Dump> read_dumps(const std::string& path) {
  std::ifstream in(path);
  std::vector<Dump> dumps;
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind("t ", 0) == 0) {
      dumps.push_back({line, {}, {}});
      continue;
    }
    if (dumps.empty() || line.empty()) continue;
    std::istringstream s(line.substr(1));
    std::vector<double>& v = line[0] == 'x' ? dumps.back().x : dumps.back().u;
    for (double d = 0.0; s >> d;)
      v.push_back(d);
  }
  return dumps;
}

void print_outputs(const plant::ContinuousModel& model, const std::vector<double>& x,
                   const std::vector<double>& u) {
  const auto& layout = model.layout();
  std::vector<double> y(model.num_outputs());
  const int status = model.outputs(x, u, y);
  std::printf("    outputs (status %d):", status);
  for (std::size_t i = 0; i < y.size(); ++i)
    std::printf(" %s=%.5g", layout.outputs[i].name.c_str(), y[i]);
  std::printf("\n");
}

void print_states(const plant::ContinuousModel& model, const std::vector<double>& x) {
  const auto& states = model.layout().states;
  std::printf("    states:");
  for (std::size_t i = 0; i < x.size(); ++i)
    std::printf(" %s=%.6g", states[i].name.c_str(), x[i]);
  std::printf("\n");
}

void print_near_bounds(const plant::ContinuousModel& model, const std::vector<double>& x) {
  const auto& states = model.layout().states;
  std::printf("    states within 2 %% of a bound:");
  for (std::size_t i = 0; i < x.size(); ++i) {
    const auto& s = states[i];
    const double w = s.max - s.min;
    if (!std::isfinite(w)) continue;
    if (x[i] - s.min < 0.02 * w || s.max - x[i] < 0.02 * w)
      std::printf(" %s=%.6g [%.4g, %.4g]", s.name.c_str(), x[i], s.min, s.max);
  }
  std::printf("\n");
}

void try_step(plant::Integrator& integ, std::vector<double> x, const std::vector<double>& u,
              double dt, const char* what) {
  std::vector<double> F(x.size() * x.size());
  const auto r = integ.step(x, u, dt, F);
  const auto& st = integ.last_stats();
  // F's largest entry: a linearisation that grows fast makes F P F' overflow the covariance.
  double largest = 0.0;
  for (const double f : F)
    largest = std::max(largest, std::abs(f));
  std::printf(
      "  %s, %.3g s: flag %d, %ld steps, %ld RHS, %ld Jacobians, %ld error-test and %ld "
      "nonlinear failures, max |F| %.3g%s%s\n",
      what, dt, r.flag, st.steps, st.rhs_evals, st.model_jacobians, st.error_test_failures,
      st.nonlinear_failures, largest, r.ok() ? "" : ": ", r.ok() ? "" : integ.last_error());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: predict_replay FILE [--index K] [--period S]\n");
    return 2;
  }
  std::size_t index = 0;
  double period = 5.0;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--index")
      index = static_cast<std::size_t>(std::atoi(argv[i + 1]));
    else if (a == "--period")
      period = std::atof(argv[i + 1]);
  }
  const auto dumps = read_dumps(argv[1]);
  if (index >= dumps.size()) {
    std::fprintf(stderr, "%s: %zu failure dumps, no index %zu\n", argv[1], dumps.size(), index);
    return 2;
  }
  const Dump& d = dumps[index];
  // A dump of the truth's integration (HeatPumpTruth::advance) replays the truth's model at its
  // tolerance; one of a filter's, the filter's.
  const bool truth = d.header.find(": truth: ") != std::string::npos;
  auto model = plant::create_model(
      "heat_pump_r32",
      truth ? bench::truth_parameters(bench::TruthKind::kNominal) : bench::filter_parameters());
  auto base_options = est::filter_integrator_options();
  if (truth) base_options.rel_tol = 1e-8;
  if (d.x.size() != model->num_states()) {
    std::fprintf(stderr, "%s: %zu states, the model has %zu\n", argv[1], d.x.size(),
                 model->num_states());
    return 2;
  }
  std::printf("%s\n", d.header.c_str());
  print_outputs(*model, d.x, d.u);
  print_states(*model, d.x);
  print_near_bounds(*model, d.x);

  plant::Integrator with_f(*model, [&] {
    auto o = base_options;
    o.sensitivities = true;
    return o;
  }());
  plant::Integrator plain(*model, base_options);
  auto unlimited_options = base_options;
  unlimited_options.max_steps = 200000;
  plant::Integrator unlimited(*model, unlimited_options);
  try_step(with_f, d.x, d.u, period, "with F");
  try_step(with_f, d.x, d.u, period, "with F, again");
  try_step(plain, d.x, d.u, period, "state only");
  try_step(plain, d.x, d.u, period, "state only, again");
  try_step(unlimited, d.x, d.u, period, "state only, 200000 steps");
  auto cvodes_options = base_options;
  cvodes_options.sensitivities = true;
  cvodes_options.sensitivity_method = plant::SensitivityMethod::kCvodesNewton;
  plant::Integrator cvodes(*model, cvodes_options);
  try_step(cvodes, d.x, d.u, period, "with F by CVODES's corrector");

  // March the state in sub-periods to see where it stops and what it looks like there.
  std::vector<double> x = d.x;
  std::vector<double> none;
  double t = 0.0;
  for (double h = period / 64.0; t < period - 1e-9;) {
    std::vector<double> trial = x;
    const auto r = plain.step(trial, d.u, h, none);
    if (!r.ok()) {
      std::printf("  stuck at %.6g s with a %.3g s sub-step: %s\n", t, h, plain.last_error());
      if (h < 1e-9) break;
      h *= 0.25;
      continue;
    }
    x = trial;
    t += h;
    std::printf("  %.6g s: %ld steps\n", t, plain.last_stats().steps);
  }
  print_outputs(*model, x, d.u);
  print_states(*model, x);
  print_near_bounds(*model, x);
  return 0;
}
