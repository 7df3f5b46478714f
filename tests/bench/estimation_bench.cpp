// The accuracy and speed benchmark of the estimators on the R32 heat pump.
//
//   estimation_bench [--short] [--hours H] [--period S] [--members N] [--threads T]
//                    [--csv FILE] [--svg FILE]
//
// Truth: heat_pump_r32 at 20 cells per heat exchanger with perturbed parameters (condenser UA
// -10 %, evaporator UA +10 %, isentropic and volumetric efficiency -5 %), driven through a
// summer day by the simulator's scenario (outdoor temperature cycle, internal-gain steps,
// thermostat and superheat controllers) with compressor-speed steps (+-8 Hz) every 20 min and
// valve steps (+-5 %) every 30 min on top.
// Measurements every period: suction and discharge pressure (sigma 0.5 % of reading), the wall
// temperatures at the inlet and outlet of both coils (sigma 0.2 K), the zone air temperature
// (sigma 0.05 K) -- nothing else from the refrigerant side. Inputs as the truth applied them.
// Filters, each on the nominal-parameter model at 10 cells (internal gains, leak rate and
// outdoor-coil fouling estimated): the EKF, the constrained EKF, the constrained EnKF. Their R
// includes representativeness error (kFilterNoiseFactor). Set BENCH_TRACE=1 for a line per step.
// Reported per filter: mean absolute percentage error of the unmeasured condenser-outlet
// pressure and valve-inlet enthalpy; error of condenser and evaporator heat flow; time-averaged
// NIS (every tested scalar innovation) and NEES (on the states the 10- and 20-cell models share:
// charge, high-side mass, liquid- and suction-line enthalpy, zone air and mass temperature,
// internal gains) against their 95 % chi-square bands; step time (median, p99) and its shares;
// and, in the same run, simulating one period with the same integrator and tolerance.
// Scores start after a 10-minute convergence window.
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "daemon/estimation/ekf.hpp"
#include "daemon/estimation/enkf.hpp"
#include "plant_models/catalog.hpp"
#include "plant_models/heat_pump/hp_layout.hpp"
#include "tests/bench/heat_pump_scenario.hpp"
#include "tests/bench/svg_plot.hpp"

using namespace hvac_twin;
using namespace hvac_twin::plant::hp;
using Clock = std::chrono::steady_clock;

namespace {

double ms_since(Clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

// Forwards to a model and times its Jacobian evaluations.
class TimedModel final : public plant::ContinuousModel {
 public:
  explicit TimedModel(std::unique_ptr<plant::ContinuousModel> m) : m_(std::move(m)) {}
  const plant::ModelLayout& layout() const override { return m_->layout(); }
  int rhs(std::span<const double> x, std::span<const double> u,
          std::span<double> f) const override {
    return m_->rhs(x, u, f);
  }
  int rhs_jacobian(std::span<const double> x, std::span<const double> u, std::span<double> f,
                   std::span<double> J) const override {
    const auto t0 = Clock::now();
    const int r = m_->rhs_jacobian(x, u, f, J);
    jacobian_ms += ms_since(t0);
    return r;
  }
  int outputs(std::span<const double> x, std::span<const double> u,
              std::span<double> y) const override {
    return m_->outputs(x, u, y);
  }
  int output_jacobian(std::span<const double> x, std::span<const double> u, std::span<double> y,
                      std::span<double> H) const override {
    const auto t0 = Clock::now();
    const int r = m_->output_jacobian(x, u, y, H);
    jacobian_ms += ms_since(t0);
    return r;
  }
  bool initial_guess(std::span<const double> u, std::span<const double> y,
                     std::span<double> x) const override {
    return m_->initial_guess(u, y, x);
  }
  std::unique_ptr<plant::ContinuousModel> clone() const override {
    return std::make_unique<TimedModel>(m_->clone());
  }
  mutable double jacobian_ms = 0.0;

 private:
  std::unique_ptr<plant::ContinuousModel> m_;
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const double last = static_cast<double>(v.size() - 1);
  return v[static_cast<std::size_t>(std::min(last, p * static_cast<double>(v.size())))];
}

// Wilson-Hilferty chi-square quantile.
double chi2_quantile(double z, double dof) {
  const double a = 2.0 / (9.0 * dof);
  return dof * std::pow(1.0 - a + z * std::sqrt(a), 3.0);
}

const std::vector<std::string> kShared{"charge", "M_cond", "h_liquid_line", "h_suction_line",
                                       "T_air",  "T_mass", "Q_int"};

struct FilterRun {
  std::string name;
  std::unique_ptr<TimedModel> model;
  std::unique_ptr<est::Estimator> filter;
  bool started = false;
  std::vector<double> step_ms, predict_ms, update_ms, jac_ms, sim_ms;
  double ape_p = 0, ape_h = 0, ae_qc = 0, ae_qe = 0, ape_qc = 0, ape_qe = 0;
  double nis = 0, nees = 0;
  long scored = 0, nis_count = 0, nees_count = 0, failures = 0;
  std::vector<double> trace_p, trace_h;
  std::vector<std::size_t> shared;  // indices of kShared in this model
};

}  // namespace

int main(int argc, char** argv) {
  double hours = 24.0, period = 5.0;
  std::size_t members = 32, threads = 2;
  std::string csv_path = "estimation_bench.csv", svg_path = "estimation_bench.svg";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto next = [&] { return i + 1 < argc ? std::string(argv[++i]) : std::string(); };
    if (a == "--short")
      hours = 1.0;
    else if (a == "--hours")
      hours = std::atof(next().c_str());
    else if (a == "--period")
      period = std::atof(next().c_str());
    else if (a == "--members")
      members = std::strtoul(next().c_str(), nullptr, 10);
    else if (a == "--threads")
      threads = std::strtoul(next().c_str(), nullptr, 10);
    else if (a == "--csv")
      csv_path = next();
    else if (a == "--svg")
      svg_path = next();
    else {
      std::fprintf(stderr,
                   "usage: estimation_bench [--short] [--hours H] [--period S] "
                   "[--members N] [--threads T] [--csv FILE] [--svg FILE]\n");
      return 2;
    }
  }

  // Truth (tests/bench/heat_pump_scenario.hpp).
  bench::HeatPumpTruth truth;
  const std::vector<double>& xt = truth.x();
  const std::vector<double>& yt = truth.y();

  // Filters on the nominal model.
  std::vector<FilterRun> runs;
  for (const char* name : {"EKF", "constrained EKF", "constrained EnKF"}) {
    FilterRun r;
    r.name = name;
    r.model = std::make_unique<TimedModel>(
        plant::create_model("heat_pump_r32", bench::filter_parameters()));
    const std::vector<double> q = bench::layout_process_noise(*r.model);
    if (r.name == "constrained EnKF") {
      est::EnkfOptions o;
      o.members = members;
      o.threads = threads;
      r.filter = std::make_unique<est::ConstrainedEnkf>(*r.model, q, bench::kMeasured.size(), o);
    } else {
      est::EkfOptions o;
      o.constrained = r.name == "constrained EKF";
      r.filter = std::make_unique<est::Ekf>(*r.model, q, bench::kMeasured.size(), o);
    }
    for (const auto& s : kShared)
      r.shared.push_back(*r.model->layout().state(s));
    runs.push_back(std::move(r));
  }
  std::vector<std::size_t> truth_shared;
  for (const auto& s : kShared)
    truth_shared.push_back(*truth.model().layout().state(s));

  std::vector<double> times_h, truth_p, truth_h;
  const int steps = static_cast<int>(hours * 3600.0 / period);
  const double warmup_s = 600.0;
  std::printf(
      "estimation_bench: %.1f simulated hours, period %.0f s, EnKF %zu members on %zu "
      "threads; truth 20 cells (perturbed), filters 10 cells\n",
      hours, period, members, threads);
  std::fflush(stdout);

  for (int k = 0; k < steps; ++k) {
    const double t = k * period;
    std::vector<double>& u = truth.drive(t, period);
    // Speed steps every 20 min and valve steps every 30 min on top of the controllers.
    u[kCompressorSpeed] = std::clamp(
        u[kCompressorSpeed] + (static_cast<int>(t / 1200.0) % 2 ? 8.0 : -8.0), 20.0, 90.0);
    u[kValveOpening] *= static_cast<int>(t / 1800.0) % 2 ? 1.05 : 0.95;
    try {
      truth.advance(period);
    } catch (const std::runtime_error& e) {
      std::fprintf(stderr, "%s at t = %g s\n", e.what(), t);
      return 1;
    }
    const std::vector<est::Measurement>& z = truth.measurements();
    const double t_end = t + period;
    const bool scoring = t_end >= warmup_s;
    if (scoring) {
      times_h.push_back(t_end / 3600.0);
      truth_p.push_back(yt[kCondenserOutletPressure]);
      truth_h.push_back(yt[kValveInletEnthalpy]);
    }

    for (auto& r : runs) {
      const std::size_t n = r.model->num_states();
      std::vector<double> y(r.model->num_outputs()), sigma(r.model->num_outputs());
      std::vector<est::MeasurementReport> reports(z.size());
      if (!r.started) {
        bench::start_filter(*r.model, *r.filter, u, truth.y_measured());
        r.filter->update(z, u, reports);
        r.started = true;
      } else {
        // The same period simulated plainly from the prior, for the speed comparison.
        std::vector<double> xs(r.filter->state().data(), r.filter->state().data() + n);
        plant::Integrator sim(*r.model, plant::IntegratorOptions{});
        const auto ts = Clock::now();
        sim.step(xs, u, period, {});
        r.sim_ms.push_back(ms_since(ts));
        const double jac0 = r.model->jacobian_ms;
        const auto t0 = Clock::now();
        if (r.filter->predict(u, period) != est::StepStatus::kOk) ++r.failures;
        const double tp = ms_since(t0);
        const auto t1 = Clock::now();
        if (r.filter->update(z, u, reports) != est::StepStatus::kOk) ++r.failures;
        const double tu = ms_since(t1);
        r.predict_ms.push_back(tp);
        r.update_ms.push_back(tu);
        r.step_ms.push_back(tp + tu);
        r.jac_ms.push_back(r.model->jacobian_ms - jac0);
        if (std::getenv("BENCH_TRACE") != nullptr) {
          const auto* ekf = dynamic_cast<const est::Ekf*>(r.filter.get());
          std::printf(
              "k %d %s predict %.1f ms (%ld steps) update %.1f ms sim %.2f ms | charge "
              "%.4f (truth %.4f) M_cond %.4f (truth %.4f) active:",
              k, r.name.c_str(), tp, ekf ? ekf->integrator().last_stats().steps : 0L, tu,
              r.sim_ms.back(), r.filter->state()(0), xt[0], r.filter->state()(1), xt[1]);
          for (const int row : r.filter->active_constraints())
            std::printf(" [%s]", r.filter->constraint_name(row).c_str());
          std::printf("\n");
          std::fflush(stdout);
        }
      }
      if (r.filter->output_estimates(u, y, sigma) != plant::kModelOk) ++r.failures;
      if (!scoring) continue;
      ++r.scored;
      r.ape_p += std::abs(y[kCondenserOutletPressure] / yt[kCondenserOutletPressure] - 1.0);
      r.ape_h += std::abs(y[kValveInletEnthalpy] / yt[kValveInletEnthalpy] - 1.0);
      r.ae_qc += std::abs(y[kCondenserHeatFlow] - yt[kCondenserHeatFlow]);
      r.ae_qe += std::abs(y[kEvaporatorHeatFlow] - yt[kEvaporatorHeatFlow]);
      r.ape_qc += std::abs(y[kCondenserHeatFlow] / yt[kCondenserHeatFlow] - 1.0);
      r.ape_qe += std::abs(y[kEvaporatorHeatFlow] / yt[kEvaporatorHeatFlow] - 1.0);
      r.trace_p.push_back(y[kCondenserOutletPressure]);
      r.trace_h.push_back(y[kValveInletEnthalpy]);
      for (const auto& rep : reports)
        if (rep.available) {
          r.nis += rep.test_ratio;
          ++r.nis_count;
        }
      const auto d = static_cast<Eigen::Index>(kShared.size());
      Eigen::VectorXd e(d);
      Eigen::MatrixXd Ps(d, d);
      for (Eigen::Index i = 0; i < d; ++i) {
        const auto fi = static_cast<Eigen::Index>(r.shared[static_cast<std::size_t>(i)]);
        e(i) = r.filter->state()(fi) - xt[truth_shared[static_cast<std::size_t>(i)]];
        for (Eigen::Index j = 0; j < d; ++j)
          Ps(i, j) = r.filter->covariance()(
              fi, static_cast<Eigen::Index>(r.shared[static_cast<std::size_t>(j)]));
      }
      const auto ldlt = Ps.ldlt();
      if (ldlt.info() == Eigen::Success) {
        r.nees += e.dot(ldlt.solve(e));
        ++r.nees_count;
      }
    }
    if (k > 0 && k % static_cast<int>(600.0 / period) == 0) {
      std::printf("  %5.2f h simulated;", t_end / 3600.0);
      for (const auto& r : runs)
        std::printf("  %s %.1f ms/step", r.name.c_str(),
                    r.step_ms.empty() ? 0.0 : percentile(r.step_ms, 0.5));
      std::printf("\n");
      std::fflush(stdout);
    }
  }

  // Report.
  std::printf("\n%-17s %9s %9s %14s %14s %16s %16s %15s %20s %6s\n", "filter", "MAPE p_co",
              "MAPE h_vi", "Q_cond MAE", "Q_evap MAE", "NIS avg [band]", "NEES avg [band]",
              "step med/p99", "predict/jac/update", "fails");
  bool pass = true;
  for (const auto& r : runs) {
    const double N = static_cast<double>(r.scored);
    const double nis = r.nis / static_cast<double>(std::max<long>(r.nis_count, 1));
    const double nees = r.nees / static_cast<double>(std::max<long>(r.nees_count, 1));
    const auto nc = static_cast<double>(std::max<long>(r.nis_count, 1));
    const double ec = static_cast<double>(std::max<long>(r.nees_count, 1));
    const double dof = static_cast<double>(kShared.size());
    char nis_band[64], nees_band[64], qc[32], qe[32], step[32], share[32];
    std::snprintf(nis_band, sizeof nis_band, "%.2f [%.2f,%.2f]", nis, chi2_quantile(-1.96, nc) / nc,
                  chi2_quantile(1.96, nc) / nc);
    std::snprintf(nees_band, sizeof nees_band, "%.1f [%.1f,%.1f]", nees,
                  chi2_quantile(-1.96, ec * dof) / ec, chi2_quantile(1.96, ec * dof) / ec);
    std::snprintf(qc, sizeof qc, "%.0f W %.1f%%", r.ae_qc / N, 100 * r.ape_qc / N);
    std::snprintf(qe, sizeof qe, "%.0f W %.1f%%", r.ae_qe / N, 100 * r.ape_qe / N);
    std::snprintf(step, sizeof step, "%.1f/%.1f ms", percentile(r.step_ms, 0.5),
                  percentile(r.step_ms, 0.99));
    double sp = 0, su = 0, sj = 0;
    for (std::size_t i = 0; i < r.step_ms.size(); ++i) {
      sp += r.predict_ms[i];
      su += r.update_ms[i];
      sj += r.jac_ms[i];
    }
    const double total = std::max(sp + su, 1e-9);
    std::snprintf(share, sizeof share, "%.0f/%.0f/%.0f %%", 100 * (sp - sj) / total,
                  100 * sj / total, 100 * su / total);
    std::printf("%-17s %8.3f%% %8.3f%% %14s %14s %16s %16s %15s %20s %6ld\n", r.name.c_str(),
                100 * r.ape_p / N, 100 * r.ape_h / N, qc, qe, nis_band, nees_band, step, share,
                r.failures);
    pass = pass && std::isfinite(r.ape_p) && std::isfinite(r.ape_h);
  }
  std::printf(
      "\n(predict/jac/update: share of step time in integration without Jacobians, in "
      "Jacobian evaluations, in the update)\n");
  for (const auto& r : runs) {
    const double sim = percentile(r.sim_ms, 0.5), step = percentile(r.step_ms, 0.5);
    std::printf(
        "%-17s median step %.2f ms = %.1f x simulating the period (%.2f ms), p99 "
        "%.2f ms\n",
        r.name.c_str(), step, step / std::max(sim, 1e-9), sim, percentile(r.step_ms, 0.99));
  }

  std::ofstream csv(csv_path);
  csv << "t_h,truth_p_cond_out_Pa";
  for (const auto& r : runs)
    csv << ",p_cond_out_" << r.name;
  csv << ",truth_h_valve_in_kJkg";
  for (const auto& r : runs)
    csv << ",h_valve_in_" << r.name;
  csv << '\n';
  for (std::size_t i = 0; i < times_h.size(); ++i) {
    csv << times_h[i] << ',' << truth_p[i];
    for (const auto& r : runs)
      csv << ',' << r.trace_p[i];
    csv << ',' << truth_h[i];
    for (const auto& r : runs)
      csv << ',' << r.trace_h[i];
    csv << '\n';
  }
  const char* colours[] = {"#d62728", "#1f77b4", "#2ca02c"};
  bench::Panel pp{"condenser-outlet pressure (unmeasured)", "kPa", {}};
  bench::Panel ph{"expansion-valve inlet enthalpy (unmeasured)", "kJ/kg", {}};
  std::vector<double> tp_kpa(truth_p.size());
  std::transform(truth_p.begin(), truth_p.end(), tp_kpa.begin(), [](double v) { return v / 1e3; });
  pp.series.push_back({"truth", "black", tp_kpa});
  ph.series.push_back({"truth", "black", truth_h});
  for (std::size_t f = 0; f < runs.size(); ++f) {
    std::vector<double> p(runs[f].trace_p.size());
    std::transform(runs[f].trace_p.begin(), runs[f].trace_p.end(), p.begin(),
                   [](double v) { return v / 1e3; });
    pp.series.push_back({runs[f].name, colours[f], p});
    ph.series.push_back({runs[f].name, colours[f], runs[f].trace_h});
  }
  bench::write_svg(svg_path, "Estimates against the simulated truth", times_h, "time [h]",
                   {pp, ph});
  std::printf("wrote %s and %s\n%s\n", csv_path.c_str(), svg_path.c_str(),
              pass ? "PASS: every filter produced finite estimates" : "FAIL: non-finite estimates");
  return pass ? 0 : 1;
}
