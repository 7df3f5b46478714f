// What the heat-pump estimation benchmarks share: the truth (heat_pump_r32 converged and with
// closures the filter's model does not share, tests/simulator/truth_model.hpp, driven by the
// simulator's scenario), the measured points with their sensor noise and the noise the filters
// assume, and a filter's start as the daemon starts it.
//
// Three truths (TruthKind): the nominal unit (only the structural differences: void fraction,
// two-phase heat transfer, friction, cell count); a unit whose parameters are off the nominal
// ones as much as units of one model differ in the field (condenser UA -20 %, evaporator UA
// +20 %, isentropic and volumetric efficiency -10 %); and the nominal unit with a biased sensor.
// Header-only; benchmarks only (allocates freely).
#pragma once

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <map>
#include <memory>
#include <random>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "daemon/estimation/estimator.hpp"
#include "plant_models/catalog.hpp"
#include "plant_models/core/integrator.hpp"
#include "plant_models/heat_pump/hp_layout.hpp"
#include "tests/simulator/scenario.hpp"
#include "tests/simulator/truth_model.hpp"

namespace hvac_twin::bench {

// Sensor noise (what the truth's measurements carry: sigma = rel * |y| + abs). The filters are
// told that sigma times filter_noise_factor: the sensor plus the representativeness error of a
// wall thermocouple the model sees as a cell mean. Measured on the nominal truth, constrained
// EKF, one hour: factor 1 gives a time-averaged NIS of 3.6 and 30 % of the condenser-outlet wall
// readings gate-rejected; 2 gives 0.95 and at most 3 %; 5 (the factor before the model's
// two-phase closure became quality-dependent) 0.17. The remaining model error belongs in Q
// (issue 12); until then this factor is the measured stand-in, not a tuning knob.
struct Measured {
  std::size_t output;
  double rel_sigma, abs_sigma;
};
inline double filter_noise_factor = 2.0;

inline const std::vector<Measured> kMeasured{
    {plant::hp::kSuctionPressure, 0.005, 0.0},  {plant::hp::kDischargePressure, 0.005, 0.0},
    {plant::hp::kCondWallTempIn, 0.0, 0.2},     {plant::hp::kCondWallTempOut, 0.0, 0.2},
    {plant::hp::kEvapWallTempIn, 0.0, 0.2},     {plant::hp::kEvapWallTempOut, 0.0, 0.2},
    {plant::hp::kZoneAirTemperature, 0.0, 0.05}};

enum class TruthKind { kNominal, kMismatched, kSensorBias };

inline const char* truth_name(TruthKind k) {
  switch (k) {
    case TruthKind::kMismatched:
      return "mismatched (UA -20/+20 %, efficiencies -10 %)";
    case TruthKind::kSensorBias:
      return "nominal, evaporator-outlet wall sensor +1 K";
    case TruthKind::kNominal:
      break;
  }
  return "nominal";
}

inline plant::ParameterMap truth_parameters(TruthKind k) {
  plant::ParameterMap p = sim::truth_closures();
  if (k == TruthKind::kMismatched) {
    p["cond_ua_air"] = 750.0 * 0.8;
    p["evap_ua_air"] = 450.0 * 1.2;
    p["comp_eta_is_peak"] = 0.70 * 0.9;
    p["comp_eta_v0"] = 0.95 * 0.9;
  }
  return p;
}

// The truth, integrated tighter than the filters (rtol 1e-8), driven by the simulator's
// heat-pump scenario; measured with seeded Gaussian sensor noise (and, for kSensorBias, one
// sensor's bias). Per period: drive(t, dt) sets the scenario's inputs (which the caller may
// change), then advance(dt) integrates over the period and measures at its end.
class HeatPumpTruth {
 public:
  explicit HeatPumpTruth(const sim::ScenarioOptions& scenario = {}, std::uint64_t noise_seed = 7,
                         TruthKind kind = TruthKind::kNominal)
      : model_(plant::create_model("heat_pump_r32", truth_parameters(kind))),
        scenario_(sim::make_scenario("heat_pump_r32", *model_, scenario)),
        x_(scenario_->initial_state()),
        u_(plant::hp::kNumInputs, 0.0),
        y_(model_->num_outputs()),
        y_measured_(model_->num_outputs(), std::nan("")),
        integrator_(*model_, tight()),
        rng_(noise_seed) {
    u_[plant::hp::kIndoorFan] = u_[plant::hp::kOutdoorFan] = 1.0;
    if (kind == TruthKind::kSensorBias) bias_[plant::hp::kEvapWallTempOut] = 1.0;  // K
  }

  // The scenario's inputs for [t, t + dt] at the current state.
  std::vector<double>& drive(double t, double dt) {
    model_->outputs(x_, u_, y_);
    scenario_->drive(t, dt, x_, y_, u_);
    return u_;
  }

  // Integrates over dt with u() held and measures at the end. Throws std::runtime_error when the
  // truth fails (a benchmark without its truth has nothing to report).
  void advance(double dt) {
    if (!integrator_.step(x_, u_, dt, {}).ok())
      throw std::runtime_error(std::string("truth integration failed: ") +
                               integrator_.last_error());
    model_->outputs(x_, u_, y_);
    z_.clear();
    for (const auto& m : kMeasured) {
      const double sd = m.rel_sigma * std::abs(y_[m.output]) + m.abs_sigma;
      const double v = y_[m.output] + bias_[m.output] + sd * noise_(rng_);
      const double sd_filter = filter_noise_factor * sd;
      z_.push_back({m.output, v, sd_filter * sd_filter, true});
      y_measured_[m.output] = v;
    }
  }

  [[nodiscard]] const plant::ContinuousModel& model() const { return *model_; }
  [[nodiscard]] const std::vector<double>& x() const { return x_; }
  [[nodiscard]] const std::vector<double>& u() const { return u_; }
  [[nodiscard]] const std::vector<double>& y() const { return y_; }
  // The last measurements, as offered to a filter (R includes representativeness error), and
  // the same values by output index (NaN where not measured).
  [[nodiscard]] const std::vector<est::Measurement>& measurements() const { return z_; }
  [[nodiscard]] const std::vector<double>& y_measured() const { return y_measured_; }

 private:
  static plant::IntegratorOptions tight() {
    plant::IntegratorOptions o;
    o.rel_tol = 1e-8;
    return o;
  }

  std::unique_ptr<plant::ContinuousModel> model_;
  std::unique_ptr<sim::Scenario> scenario_;
  std::vector<double> x_, u_, y_, y_measured_;
  std::array<double, plant::hp::kNumOutputs> bias_{};  // sensor bias per output [output unit]
  std::vector<est::Measurement> z_;
  plant::Integrator integrator_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> noise_{0.0, 1.0};
};

// The filters' model: the nominal parameters at the default cell count with what the daemon's
// heat-pump configuration augments (config/demo-heat-pump.json: outdoor-coil fouling).
// Benchmarks may change it (estimation_bench --set), and the random walks and consider flags
// below, before they build a filter. Tried on the nominal truth, one hour: augmenting the other
// factors as well (indoor UA, compressor flow and efficiency, valve) and calibrating the void
// exponent while commissioning drove the filter into gate rejections of 40-57 % after the
// commissioning hour; the void exponent considered at its prior left the charge 6 % high at
// 12 sigma. Neither is the default until it is shown to hold.
inline plant::ParameterMap& filter_parameters() {
  static plant::ParameterMap p{{"augment_fouling", 1}};
  return p;
}
// Commissioning (daemon/estimation/commissioning.hpp): for this long after the start the filters
// know the truth's charge (weighed in, sigma 5 g) and calibrate the closures marked for it
// (estimation_bench --commission H; 0, the default: no commissioning).
inline double commissioning_s = 0.0;
inline constexpr double kWeighingSigma = 0.005;  // kg
// The filters hold their parameters this long after the start (est::StatePhases).
inline constexpr double kSettleS = 600.0;
inline std::map<std::string, double>& process_noise_overrides() {
  static std::map<std::string, double> q;
  return q;
}
inline std::map<std::string, bool>& consider_overrides() {
  static std::map<std::string, bool> c;
  return c;
}

// The layout's random-walk intensities with the overrides, the filters' Q.
inline std::vector<double> layout_process_noise(const plant::ContinuousModel& model) {
  std::vector<double> q;
  for (const auto& s : model.layout().states) {
    const auto it = process_noise_overrides().find(s.name);
    q.push_back(it != process_noise_overrides().end() ? it->second : s.process_noise);
  }
  return q;
}

// As the daemon starts a filter: the model's guess at the measured conditions, settled for
// 10 min with the inputs held. The settled guess is consistent; the spread is a fifth of the
// layout's default (with the full spread the first nonlinear update lands in a stiff corner
// and the first predictions take seconds).
inline void start_filter(const plant::ContinuousModel& model, est::Estimator& filter,
                         std::span<const double> u, std::span<const double> y_measured) {
  std::vector<double> x0(model.num_states()), s0;
  model.initial_guess(u, y_measured, x0);
  plant::Integrator settle(model, plant::IntegratorOptions{});
  settle.step(x0, u, 600.0, {});
  for (const auto& s : model.layout().states)
    s0.push_back(s.augmented ? s.initial_std : 0.2 * s.initial_std);
  filter.reset(x0, s0);
}

}  // namespace hvac_twin::bench
