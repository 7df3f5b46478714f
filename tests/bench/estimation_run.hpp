// One filter on the heat-pump truth, for estimation_bench: the filter (EKF, constrained EKF or
// constrained EnKF on the filters' model), its step timing against a plain simulation of the
// same period, and the consistency accumulators of tests/bench/consistency.hpp for the virtual
// sensors, the charge, each measured point, the NIS and the NEES.
// Header-only; benchmarks only (allocates freely).
#pragma once

#include <Eigen/Dense>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "daemon/estimation/commissioning.hpp"
#include "daemon/estimation/ekf.hpp"
#include "daemon/estimation/enkf.hpp"
#include "plant_models/catalog.hpp"
#include "plant_models/heat_pump/hp_layout.hpp"
#include "tests/bench/consistency.hpp"
#include "tests/bench/heat_pump_scenario.hpp"

namespace hvac_twin::bench {

using Clock = std::chrono::steady_clock;

inline double ms_since(Clock::time_point t0) {
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

// The virtual sensors whose sigma the benchmark checks, and the states the filter and the truth
// share (for the NEES).
inline const std::vector<std::size_t>& checked_outputs() {
  using namespace plant::hp;
  static const std::vector<std::size_t> o{
      kCondenserOutletPressure, kValveInletEnthalpy, kCondenserHeatFlow, kEvaporatorHeatFlow,
      kCoolingCapacity,         kSuperheat,          kSubcooling,        kCharge};
  return o;
}
inline const std::vector<std::string>& shared_states() {
  static const std::vector<std::string> s{"charge", "M_cond", "h_liquid_line", "h_suction_line",
                                          "T_air",  "T_mass", "Q_int"};
  return s;
}
// The NEES is taken on the physical quantities filter and truth share as the filter publishes
// them, with the covariance it publishes: H P H' through the output Jacobian plus each one's
// structural model error (SignalInfo::model_error). Not on the states themselves: the model's
// charge and high-side mass are its own inventory, which its void-fraction closure sets apart
// from the truth's by a structural offset no state covariance carries (the published charge's
// sigma does).
inline const std::vector<std::size_t>& nees_outputs() {
  using namespace plant::hp;
  static const std::vector<std::size_t> o{kCharge, kValveInletEnthalpy, kZoneAirTemperature,
                                          kMassTemperature, kInternalGains};
  return o;
}

// The environment variable `name` as a number, or `fallback` when it is not set (a knob to compare
// settings with; see the callers).
inline double number_from_env(const char* name, double fallback) {
  const char* v = std::getenv(name);
  return v != nullptr ? std::atof(v) : fallback;
}

// A relative tolerance from the environment variable `name`, if set, with the absolute
// tolerances scaled alike (the model's are meant for 1e-6).
inline void tolerance_from_env(plant::IntegratorOptions& o, const char* name) {
  if (const char* tol = std::getenv(name)) {
    o.rel_tol = std::atof(tol);
    o.abs_tol_scale = o.rel_tol / 1e-6;
  }
}

// The parameters' release ramp, the daemon's default (estimator.parameter_release_s), or env
// BENCH_RELEASE_S to compare (0: at once).
inline double release_s() {
  return number_from_env("BENCH_RELEASE_S", config::EstimatorConfig{}.parameter_release_s);
}

// The plain simulation the step is timed against: the EKF's state tolerances (BENCH_RTOL
// included), without F.
inline plant::IntegratorOptions plain_options() {
  plant::IntegratorOptions o;
  const plant::IntegratorOptions f = est::filter_integrator_options();
  o.rel_tol = f.rel_tol;
  o.abs_tol_scale = f.abs_tol_scale;
  tolerance_from_env(o, "BENCH_RTOL");
  return o;
}

struct FilterRun {
  std::string name;
  std::unique_ptr<TimedModel> model;
  std::unique_ptr<est::Estimator> filter;
  bool started = false;
  std::unique_ptr<est::StatePhases> phases;
  std::vector<double> step_ms, predict_ms, update_ms, jac_ms, sim_ms;
  // The published estimates after every step but the first (output_estimates), and, on scored
  // steps, one output Jacobian at the same estimate (what the publication costs when it cannot
  // reuse the update's).
  std::vector<double> publish_ms, output_jacobian_ms;
  std::vector<Quantity> outputs;  // by checked_outputs()
  std::vector<Sensor> sensors;    // by kMeasured
  double nis_sum = 0.0, nees_sum = 0.0;
  // Per NEES quantity (nees_outputs()): the sum of e^2 / sigma^2 on its own, where the NEES's
  // excess or shortfall sits (the terms do not add up to the NEES: it weighs their correlations).
  std::vector<double> nees_terms;
  long nis_count = 0, nees_count = 0, failures = 0;
  std::vector<std::vector<double>>
      trace;                        // per scored period: estimate, sigma of each checked output
  std::vector<std::size_t> shared;  // indices of shared_states() in the filter's model
  std::vector<std::size_t> truth_shared;   // ... and in the truth's
  std::vector<double> last_y, last_sigma;  // the outputs after the last step, with their sigma
  std::vector<est::MeasurementReport> last_reports;    // the last update's, when scored
  std::optional<AdaptedMeasurements> offered;          // made at the first step (its period)
  est::TrackMonitor track{est::kLostAfterUpdates, 0};  // what the adapter leaves out

  FilterRun(const std::string& filter_name, const plant::ContinuousModel& truth_model,
            std::size_t members, std::size_t threads)
      : name(filter_name),
        model(std::make_unique<TimedModel>(
            plant::create_model("heat_pump_r32", filter_parameters()))) {
    const std::vector<double> q = layout_process_noise(*model);
    if (name == "constrained EnKF") {
      est::EnkfOptions o;
      o.members = members;
      o.threads = threads;
      tolerance_from_env(o.integrator, "BENCH_ENKF_RTOL");  // the members' tolerance
      // The members' Jacobian reuse distance (est::member_integrator_options) and their lanes.
      o.integrator.jacobian_reuse_sigma =
          number_from_env("BENCH_ENKF_JACOBIAN_REUSE", o.integrator.jacobian_reuse_sigma);
      o.lanes = static_cast<std::size_t>(
          number_from_env("BENCH_ENKF_LANES", static_cast<double>(o.lanes)));
      filter = std::make_unique<est::ConstrainedEnkf>(*model, q, kMeasured.size(), o);
    } else {
      est::EkfOptions o;
      o.constrained = name == "constrained EKF";
      tolerance_from_env(o.integrator, "BENCH_RTOL");
      // The Jacobian reuse distance (IntegratorOptions::jacobian_reuse_sigma), to compare.
      o.integrator.jacobian_reuse_sigma =
          number_from_env("BENCH_JACOBIAN_REUSE", o.integrator.jacobian_reuse_sigma);
      // BENCH_DIRECT=1: F by CVODES's per-step direct sensitivity solve
      // (plant::SensitivityMethod::kDirect) instead of the filters' matrix exponentials, to
      // compare.
      if (const char* d = std::getenv("BENCH_DIRECT"); d != nullptr && std::atoi(d) == 1)
        o.integrator.sensitivity_method = plant::SensitivityMethod::kDirect;
      filter = std::make_unique<est::Ekf>(*model, q, kMeasured.size(), o);
    }
    for (const std::size_t i : checked_outputs())
      outputs.emplace_back(model->layout().outputs[i].name);
    for (const auto& m : kMeasured)
      sensors.emplace_back(model->layout().outputs[m.output].name);
    for (const auto& s : shared_states()) {
      shared.push_back(*model->layout().state(s));
      truth_shared.push_back(*truth_model.layout().state(s));
    }
  }

  // One period (from t): predict and update on the truth's measurements, timed against a plain
  // simulation of the period from the prior; then, if scoring, every accumulator.
  void step(std::vector<double>& u, const HeatPumpTruth& truth, double t, double period,
            bool scoring) {
    if (!offered) offered.emplace(period);
    const std::vector<est::Measurement>& z = offered->offer(truth.measurements());
    const std::size_t n = model->num_states();
    std::vector<est::MeasurementReport> reports(z.size());
    if (!started) {
      start_filter(*model, *filter, u, truth.y_measured());
      phases = std::make_unique<est::StatePhases>(
          model->layout(),
          commissioning_s > 0.0
              ? std::vector<est::KnownState>{{"charge", truth.x()[0], kWeighingSigma}}
              : std::vector<est::KnownState>{},
          kSettleS, commissioning_s, release_s());
      const auto& states = model->layout().states;
      for (std::size_t i = 0; i < states.size(); ++i) {
        const auto it = consider_overrides().find(states[i].name);
        if (it != consider_overrides().end()) phases->set_base(i, it->second);
      }
      const std::string error = phases->begin(*filter, t);
      if (!error.empty()) throw std::runtime_error(error);
      filter->update(z, u, reports);
      started = true;
    } else {
      phases->apply(*filter, t, u);
      std::vector<double> xs(filter->state().data(), filter->state().data() + n);
      plant::Integrator sim(*model, plain_options());
      const auto ts = Clock::now();
      sim.step(xs, u, period, {});
      sim_ms.push_back(ms_since(ts));
      const double jac0 = model->jacobian_ms;
      const auto t0 = Clock::now();
      if (filter->predict(u, period) != est::StepStatus::kOk) ++failures;
      const double tp = ms_since(t0);
      const auto resets_before = filter->counters().covariance_resets;
      const auto t1 = Clock::now();
      if (filter->update(z, u, reports) != est::StepStatus::kOk) ++failures;
      const double tu = ms_since(t1);
      const bool covariance_reset = filter->counters().covariance_resets != resets_before;
      offered->observe(reports, track.observe(reports, covariance_reset).lost || covariance_reset);
      predict_ms.push_back(tp);
      update_ms.push_back(tu);
      step_ms.push_back(tp + tu);
      jac_ms.push_back(model->jacobian_ms - jac0);
    }
    std::vector<double>& y = last_y;
    std::vector<double>& sigma = last_sigma;
    y.assign(model->num_outputs(), 0.0);
    sigma.assign(model->num_outputs(), 0.0);
    const auto tp0 = Clock::now();
    if (filter->output_estimates(u, y, sigma) != plant::kModelOk) ++failures;
    if (!step_ms.empty()) publish_ms.push_back(ms_since(tp0));
    if (!scoring) return;
    const std::vector<double>& yt = truth.y();
    for (std::size_t k = 0; k < checked_outputs().size(); ++k) {
      const std::size_t o = checked_outputs()[k];
      if (o == plant::hp::kCharge && phases->commissioning(t)) continue;  // held: weighed in
      outputs[k].add(y[o], sigma[o], yt[o]);
    }
    trace.emplace_back();
    for (const std::size_t o : checked_outputs()) {
      trace.back().push_back(y[o]);
      trace.back().push_back(sigma[o]);
    }
    last_reports = reports;
    for (std::size_t i = 0; i < reports.size(); ++i) {
      sensors[i].add(reports[i].available, reports[i].test_ratio, reports[i].rejected);
      if (reports[i].available) {
        nis_sum += reports[i].test_ratio;
        ++nis_count;
      }
    }
    const auto& outs = nees_outputs();
    const auto d = static_cast<Eigen::Index>(outs.size());
    const auto no = static_cast<Eigen::Index>(model->num_outputs());
    Eigen::MatrixXd H(no, static_cast<Eigen::Index>(n));
    std::vector<double> yh(model->num_outputs());
    const std::vector<double> x(filter->state().data(), filter->state().data() + n);
    const auto th0 = Clock::now();
    const int h_status =
        model->output_jacobian(x, u, yh, {H.data(), static_cast<std::size_t>(H.size())});
    output_jacobian_ms.push_back(ms_since(th0));
    if (h_status != plant::kModelOk) return;
    Eigen::MatrixXd Hs(d, static_cast<Eigen::Index>(n));
    Eigen::VectorXd e(d);
    for (Eigen::Index i = 0; i < d; ++i) {
      const std::size_t o = outs[static_cast<std::size_t>(i)];
      Hs.row(i) = H.row(static_cast<Eigen::Index>(o));
      e(i) = y[o] - truth.y()[o];
    }
    Eigen::MatrixXd Ps = Hs * filter->covariance() * Hs.transpose();
    for (Eigen::Index i = 0; i < d; ++i) {
      const auto& info = model->layout().outputs[outs[static_cast<std::size_t>(i)]];
      const double me = std::hypot(
          info.model_error, info.model_error_rel * std::abs(y[outs[static_cast<std::size_t>(i)]]));
      Ps(i, i) += me * me;
    }
    (void)no;
    const auto ldlt = Ps.ldlt();
    if (ldlt.info() == Eigen::Success) {
      nees_sum += e.dot(ldlt.solve(e));
      ++nees_count;
      nees_terms.resize(static_cast<std::size_t>(d), 0.0);
      for (Eigen::Index i = 0; i < d; ++i)
        nees_terms[static_cast<std::size_t>(i)] += e(i) * e(i) / Ps(i, i);
    }
  }

  // For BENCH_TRACE: the integrator's work in the last predict (EKF), the factors, and the
  // checked outputs as estimate-truth in sigmas.
  [[nodiscard]] std::string trace_line(const std::vector<double>& y_truth,
                                       const std::vector<double>& truth_x) const {
    std::string out;
    char buf[160];
    for (const std::size_t o : checked_outputs())
      if (o < last_y.size()) {
        std::snprintf(buf, sizeof buf, "%.6s %+.1f ", model->layout().outputs[o].name.c_str(),
                      (last_y[o] - y_truth[o]) / std::max(last_sigma[o], 1e-300));
        out += buf;
      }
    for (std::size_t i = 4; i < shared.size(); ++i) {  // T_air, T_mass, Q_int
      std::snprintf(buf, sizeof buf, "%s %.3f (%.3f) ", shared_states()[i].c_str(),
                    filter->state()(static_cast<Eigen::Index>(shared[i])),
                    truth_x[truth_shared[i]]);
      out += buf;
    }
    out += "| innov ";
    for (const auto& r : last_reports) {
      std::snprintf(buf, sizeof buf, "%+.1f ",
                    r.innovation / std::sqrt(std::max(r.innovation_variance, 1e-300)));
      out += buf;
    }
    out += "| ";
    if (const auto* ekf = dynamic_cast<const est::Ekf*>(filter.get())) {
      const plant::IntegrationStats& s = ekf->integrator().last_stats();
      std::snprintf(buf, sizeof buf, "steps %ld rhs %ld jac %ld nlfail %ld etf %ld |", s.steps,
                    s.rhs_evals, s.model_jacobians, s.nonlinear_failures, s.error_test_failures);
      out += buf;
    }
    const auto& states = model->layout().states;
    const Eigen::MatrixXd& P = filter->covariance();
    for (std::size_t i = 0; i < states.size(); ++i)
      if (states[i].augmented && states[i].unit == "1") {
        const auto k = static_cast<Eigen::Index>(i);
        // The factor, its sigma, and the charge's regression on it (kg per unit factor).
        std::snprintf(buf, sizeof buf, " %.8s %.3f +-%.3f (dm/df %.3f)", states[i].name.c_str(),
                      filter->state()(k), std::sqrt(P(k, k)), P(0, k) / P(k, k));
        out += buf;
      }
    std::snprintf(buf, sizeof buf, " | sigma charge %.4f", std::sqrt(P(0, 0)));
    out += buf;
    return out;
  }

  [[nodiscard]] double nis() const {
    return nis_count ? nis_sum / static_cast<double>(nis_count) : 0.0;
  }
  [[nodiscard]] double nees() const {
    return nees_count ? nees_sum / static_cast<double>(nees_count) : 0.0;
  }
  [[nodiscard]] double nees_term(std::size_t k) const {
    return nees_count && k < nees_terms.size() ? nees_terms[k] / static_cast<double>(nees_count)
                                               : 0.0;
  }
  [[nodiscard]] const Quantity& output(std::size_t model_output) const {
    for (std::size_t k = 0; k < checked_outputs().size(); ++k)
      if (checked_outputs()[k] == model_output) return outputs[k];
    return outputs.front();
  }
};

}  // namespace hvac_twin::bench
