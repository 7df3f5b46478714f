// fmu_bench: what the FMI boundary costs (issue 14's aim: at most 1.5x the built-in model's step
// at equal model). The heat pump as the build exports it (the demo's structure), built in and
// through its FMU (build/fmu/heat_pump_r32.fmu), from the same operating point:
//   predict   one 5 s estimator period integrated by CVODES with forward sensitivities (F), the
//             bulk of an EKF step
//   update    the output Jacobian H at the predicted state
// timed alternately (built-in, FMU, built-in, ...) so both see the same machine; medians and
// their ratio. Prints its figures; exits 0 unless a model fails.
//
//   fmu_bench [--short]     --short: 15 repetitions (CI); default 100
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include "io/fmi/import/fmu_model.hpp"
#include "plant_models/core/integrator.hpp"
#include "tests/unit/plant_models/heat_pump_fixture.hpp"

namespace {

using namespace hvac_twin;
using Clock = std::chrono::steady_clock;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

}  // namespace

int main(int argc, char** argv) {
  const bool short_run = argc > 1 && std::strcmp(argv[1], "--short") == 0;
  const int reps = short_run ? 15 : 100;
  std::string dir =
      (std::filesystem::temp_directory_path() / "hvac-twin-fmu-bench-XXXXXX").string();
  if (::mkdtemp(dir.data()) == nullptr) {
    std::perror("mkdtemp");
    return 1;
  }
  int rc = 0;
  try {
    const auto lib =
        fmi::load_fmu(std::string(HVAC_TWIN_FMU_DIR) + "/heat_pump_r32.fmu", dir + "/unpacked");
    const fmi::FmuModel fmu(lib, {});
    const test::HeatPumpRig rig(test::demo_structure());
    const plant::ContinuousModel& builtin = *rig.model;
    const auto u = test::nominal_inputs();
    auto x0 = rig.start();
    rig.run(x0, u, 300.0);  // a running cycle near its operating point
    const std::size_t n = builtin.num_states(), m = builtin.num_outputs();

    plant::IntegratorOptions opt;
    opt.sensitivities = true;
    plant::Integrator integ_builtin(builtin, opt), integ_fmu(fmu, opt);
    std::vector<double> F(n * n), H(m * n), y(m);
    std::vector<double> predict[2], update[2];
    const plant::ContinuousModel* models[2] = {&builtin, &fmu};
    plant::Integrator* integrators[2] = {&integ_builtin, &integ_fmu};
    for (int r = 0; r < reps; ++r) {
      for (int k = 0; k < 2; ++k) {
        auto x = x0;
        auto start = Clock::now();
        if (!integrators[k]->step(x, u, 5.0, F).ok())
          throw std::runtime_error(std::string("integration failed: ") +
                                   integrators[k]->last_error());
        predict[k].push_back(ms_since(start));
        start = Clock::now();
        if (models[k]->output_jacobian(x, u, y, H) != plant::kModelOk)
          throw std::runtime_error("output Jacobian failed");
        update[k].push_back(ms_since(start));
      }
    }
    const double p0 = median(predict[0]), p1 = median(predict[1]);
    const double u0 = median(update[0]), u1 = median(update[1]);
    std::printf("fmu_bench: heat pump (%zu states, %zu outputs), %d repetitions, medians\n", n, m,
                reps);
    std::printf(
        "  predict (5 s, CVODES with sensitivities): built-in %.2f ms, FMU %.2f ms, "
        "ratio %.2f (aim <= 1.5%s)\n",
        p0, p1, p1 / p0, p1 / p0 <= 1.5 ? "" : ": MISSED");
    std::printf("  update (output Jacobian): built-in %.3f ms, FMU %.3f ms, ratio %.2f\n", u0, u1,
                u1 / u0);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fmu_bench: %s\n", e.what());
    rc = 1;
  }
  std::error_code ec;
  std::filesystem::remove_all(dir, ec);
  return rc;
}
