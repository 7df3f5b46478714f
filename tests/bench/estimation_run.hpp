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

struct FilterRun {
  std::string name;
  std::unique_ptr<TimedModel> model;
  std::unique_ptr<est::Estimator> filter;
  bool started = false;
  std::unique_ptr<est::StatePhases> phases;
  std::vector<double> step_ms, predict_ms, update_ms, jac_ms, sim_ms;
  std::vector<Quantity> outputs;  // by checked_outputs()
  std::vector<Sensor> sensors;    // by kMeasured
  double nis_sum = 0.0, nees_sum = 0.0;
  long nis_count = 0, nees_count = 0, failures = 0;
  std::vector<double> trace_p, trace_h;
  std::vector<std::size_t> shared;        // indices of shared_states() in the filter's model
  std::vector<std::size_t> truth_shared;  // ... and in the truth's

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
      filter = std::make_unique<est::ConstrainedEnkf>(*model, q, kMeasured.size(), o);
    } else {
      est::EkfOptions o;
      o.constrained = name == "constrained EKF";
      if (const char* tol = std::getenv("BENCH_RTOL")) {
        o.integrator.rel_tol = std::atof(tol);
        o.integrator.abs_tol_scale = o.integrator.rel_tol / 1e-6;
      }
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
    const std::vector<est::Measurement>& z = truth.measurements();
    const std::size_t n = model->num_states();
    std::vector<est::MeasurementReport> reports(z.size());
    if (!started) {
      start_filter(*model, *filter, u, truth.y_measured());
      phases = std::make_unique<est::StatePhases>(
          model->layout(),
          commissioning_s > 0.0
              ? std::vector<est::KnownState>{{"charge", truth.x()[0], kWeighingSigma}}
              : std::vector<est::KnownState>{},
          kSettleS, commissioning_s);
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
      phases->apply(*filter, t);
      std::vector<double> xs(filter->state().data(), filter->state().data() + n);
      plant::Integrator sim(*model, plant::IntegratorOptions{});
      const auto ts = Clock::now();
      sim.step(xs, u, period, {});
      sim_ms.push_back(ms_since(ts));
      const double jac0 = model->jacobian_ms;
      const auto t0 = Clock::now();
      if (filter->predict(u, period) != est::StepStatus::kOk) ++failures;
      const double tp = ms_since(t0);
      const auto t1 = Clock::now();
      if (filter->update(z, u, reports) != est::StepStatus::kOk) ++failures;
      const double tu = ms_since(t1);
      predict_ms.push_back(tp);
      update_ms.push_back(tu);
      step_ms.push_back(tp + tu);
      jac_ms.push_back(model->jacobian_ms - jac0);
    }
    std::vector<double> y(model->num_outputs()), sigma(model->num_outputs());
    if (filter->output_estimates(u, y, sigma) != plant::kModelOk) ++failures;
    if (!scoring) return;
    const std::vector<double>& yt = truth.y();
    for (std::size_t k = 0; k < checked_outputs().size(); ++k) {
      const std::size_t o = checked_outputs()[k];
      if (o == plant::hp::kCharge && phases->commissioning(t)) continue;  // held: weighed in
      outputs[k].add(y[o], sigma[o], yt[o]);
    }
    trace_p.push_back(y[plant::hp::kCondenserOutletPressure]);
    trace_h.push_back(y[plant::hp::kValveInletEnthalpy]);
    for (std::size_t i = 0; i < reports.size(); ++i) {
      sensors[i].add(reports[i].available, reports[i].test_ratio, reports[i].rejected);
      if (reports[i].available) {
        nis_sum += reports[i].test_ratio;
        ++nis_count;
      }
    }
    const auto d = static_cast<Eigen::Index>(shared.size());
    Eigen::VectorXd e(d);
    Eigen::MatrixXd Ps(d, d);
    for (Eigen::Index i = 0; i < d; ++i) {
      const auto fi = static_cast<Eigen::Index>(shared[static_cast<std::size_t>(i)]);
      e(i) = filter->state()(fi) - truth.x()[truth_shared[static_cast<std::size_t>(i)]];
      for (Eigen::Index j = 0; j < d; ++j)
        Ps(i, j) = filter->covariance()(
            fi, static_cast<Eigen::Index>(shared[static_cast<std::size_t>(j)]));
    }
    const auto ldlt = Ps.ldlt();
    if (ldlt.info() == Eigen::Success) {
      nees_sum += e.dot(ldlt.solve(e));
      ++nees_count;
    }
  }

  // For BENCH_TRACE: the integrator's work in the last predict (EKF) and the factors.
  [[nodiscard]] std::string trace_line() const {
    std::string out;
    char buf[160];
    if (const auto* ekf = dynamic_cast<const est::Ekf*>(filter.get())) {
      const plant::IntegrationStats& s = ekf->integrator().last_stats();
      std::snprintf(buf, sizeof buf, "steps %ld rhs %ld jac %ld nlfail %ld etf %ld |", s.steps,
                    s.rhs_evals, s.model_jacobians, s.nonlinear_failures, s.error_test_failures);
      out += buf;
    }
    const auto& states = model->layout().states;
    for (std::size_t i = 0; i < states.size(); ++i)
      if (states[i].augmented && states[i].unit == "1") {
        std::snprintf(buf, sizeof buf, " %.8s %.3f", states[i].name.c_str(),
                      filter->state()(static_cast<Eigen::Index>(i)));
        out += buf;
      }
    return out;
  }

  [[nodiscard]] double nis() const {
    return nis_count ? nis_sum / static_cast<double>(nis_count) : 0.0;
  }
  [[nodiscard]] double nees() const {
    return nees_count ? nees_sum / static_cast<double>(nees_count) : 0.0;
  }
  [[nodiscard]] const Quantity& output(std::size_t model_output) const {
    for (std::size_t k = 0; k < checked_outputs().size(); ++k)
      if (checked_outputs()[k] == model_output) return outputs[k];
    return outputs.front();
  }
};

}  // namespace hvac_twin::bench
