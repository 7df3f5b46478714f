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
#include <cstdio>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "daemon/estimation/estimator.hpp"
#include "daemon/estimation/noise_adapter.hpp"
#include "daemon/estimation/track_monitor.hpp"
#include "plant_models/catalog.hpp"
#include "plant_models/core/integrator.hpp"
#include "plant_models/core/settling.hpp"
#include "plant_models/heat_pump/hp_layout.hpp"
#include "tests/simulator/scenario.hpp"
#include "tests/simulator/truth_model.hpp"

namespace hvac_twin::bench {

// Sensor noise (what the truth's measurements carry: sigma = rel * |y| + abs), and what the
// filters are told: that sigma times filter_noise_factor (1), in quadrature with the point's
// representativeness error `repr`. A wall thermocouple reads the wall at one end of a coil; the
// model has that wall as a state of its own (end_walls), so what is left is the closures the
// unit does not share: at the evaporator's outlet its dryout (from a quality of 0.75 against the
// model's 0.8), 0.15 K; none at the other three ends. The pressures are the compressor's, which
// the model has exactly, and the zone air is a state of the zone model the truth shares: none.
// Measured on the three truths (constrained EKF, one hour, stop 58): the walls' NIS 0.83-1.02
// (the biased sensor's 2.9); with 0.25 K on all four, as before the end walls, 0.39-0.76 and the
// overall NIS 0.62 on the nominal truth; with none, the evaporator outlet's 1.27-1.31 (end
// walls' random walk 0.01 K/sqrt(s) in the last two).
// estimation_bench --noise-factor and --repr change it.
struct Measured {
  std::size_t output;
  double rel_sigma, abs_sigma;
  double repr;
};
inline double filter_noise_factor = 1.0;
// The daemon's estimator.adaptive_noise_min / _max (daemon/estimation/noise_adapter.hpp), over
// its default consistency window (3600 s), at the daemon's defaults; both 1: off.
inline double adaptive_noise_min = config::EstimatorConfig{}.adaptive_noise_min,
              adaptive_noise_max = config::EstimatorConfig{}.adaptive_noise_max;
// The measurements a filter is offered: the truth's, their variances adapted as the daemon adapts
// them when adaptive_noise_min/max say so (UnitPipeline::build_measurements), else as told.
class AdaptedMeasurements {
 public:
  explicit AdaptedMeasurements(double period_s) {
    if (adaptive_noise_min < 1.0 || adaptive_noise_max > 1.0)
      options_ = est::NoiseAdapterOptions{
          .window_cycles = static_cast<std::size_t>(std::llround(3600.0 / period_s)),
          .min_samples = 30,
          .min_factor = adaptive_noise_min,
          .max_factor = adaptive_noise_max,
          .hold_updates = est::kLostAfterUpdates};
  }
  // Before the update: the truth's measurements with the variances to offer.
  const std::vector<est::Measurement>& offer(const std::vector<est::Measurement>& told) {
    z_ = told;
    if (!options_) return z_;
    if (!adapter_) {
      adapter_ = std::make_unique<est::NoiseAdapter>(told.size(), *options_);
      told_.resize(told.size());
    }
    // The told variances are this cycle's: a pressure transmitter's noise is a share of its
    // reading, so they move with the operating point. (Kept from the first cycle, as they were
    // until stop 59, the pressures' were those of the start's pressures: on the nominal truth
    // the suction pressure's NIS read 0.45 where against this cycle's noise it is 0.59.)
    for (std::size_t i = 0; i < z_.size(); ++i) {
      told_[i] = told[i].variance;
      z_[i].variance = adapter_->variance(i, told_[i]);
    }
    return z_;
  }
  // After the update: its reports, and whether the daemon would discard them (the track lost,
  // the covariance reset or the filter restarted; UnitPipeline::run_cycle).
  void observe(const std::vector<est::MeasurementReport>& reports, bool discard) {
    if (adapter_ && discard) adapter_->discard_held();
    if (adapter_ && !discard) adapter_->observe(z_, reports, told_);
  }

 private:
  std::optional<est::NoiseAdapterOptions> options_;
  std::unique_ptr<est::NoiseAdapter> adapter_;
  std::vector<est::Measurement> z_;
  std::vector<double> told_;
};
// Representativeness errors set on the command line (estimation_bench --repr OUTPUT=SIGMA),
// replacing the point's own [output unit].
inline std::map<std::size_t, double>& representativeness() {
  static std::map<std::size_t, double> r;
  return r;
}

inline const std::vector<Measured> kMeasured{{plant::hp::kSuctionPressure, 0.005, 0.0, 0.0},
                                             {plant::hp::kDischargePressure, 0.005, 0.0, 0.0},
                                             {plant::hp::kCondWallTempIn, 0.0, 0.2, 0.0},
                                             {plant::hp::kCondWallTempOut, 0.0, 0.2, 0.0},
                                             {plant::hp::kEvapWallTempIn, 0.0, 0.2, 0.0},
                                             {plant::hp::kEvapWallTempOut, 0.0, 0.2, 0.15},
                                             {plant::hp::kZoneAirTemperature, 0.0, 0.05, 0.0}};

// One failed integration, to replay it alone (predict_replay): the time, whose integration
// ("filter" or "truth") and the integrator's message, then the state and the inputs before it.
template <class Vector>
void dump_failure(std::FILE* f, double t, const char* who, const char* error, const Vector& x,
                  const std::vector<double>& u) {
  std::fprintf(f, "t %.1f: %s: %s\nx", t, who, error);
  for (const double v : x)
    std::fprintf(f, " %.17g", v);
  std::fprintf(f, "\nu");
  for (const double v : u)
    std::fprintf(f, " %.17g", v);
  std::fprintf(f, "\n");
  std::fflush(f);
}

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

// Parameters set on every truth after its kind's (estimation_bench --truth-set): for studies,
// e.g. a truth that is the filters' own model with one parameter off.
inline plant::ParameterMap& truth_overrides() {
  static plant::ParameterMap p;
  return p;
}

inline plant::ParameterMap truth_parameters(TruthKind k) {
  plant::ParameterMap p = sim::truth_closures();
  for (const auto& [key, value] : truth_overrides())
    p[key] = value;
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
  // truth fails (a benchmark without its truth has nothing to report), after writing the state
  // and inputs it failed from to failure_dump when set (predict_replay --truth replays it).
  void advance(double dt) {
    x_before_ = x_;
    if (!integrator_.step(x_, u_, dt, {}).ok()) {
      if (failure_dump != nullptr)
        dump_failure(failure_dump, t_, "truth", integrator_.last_error(), x_before_, u_);
      throw std::runtime_error(std::string("truth integration failed: ") +
                               integrator_.last_error());
    }
    t_ += dt;
    model_->outputs(x_, u_, y_);
    z_.clear();
    for (const auto& m : kMeasured) {
      const double sd = m.rel_sigma * std::abs(y_[m.output]) + m.abs_sigma;
      const double v = y_[m.output] + bias_[m.output] + sd * noise_(rng_);
      const auto repr = representativeness().find(m.output);
      const double extra = repr == representativeness().end() ? m.repr : repr->second;
      const double sd_filter = std::hypot(filter_noise_factor * sd, extra);
      z_.push_back({m.output, v, sd_filter * sd_filter, true});
      y_measured_[m.output] = v;
    }
  }

  std::FILE* failure_dump = nullptr;

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
  std::vector<double> x_, u_, y_, y_measured_, x_before_;
  double t_ = 0.0;                                     // time integrated so far [s]
  std::array<double, plant::hp::kNumOutputs> bias_{};  // sensor bias per output [output unit]
  std::vector<est::Measurement> z_;
  plant::Integrator integrator_;
  std::mt19937_64 rng_;
  std::normal_distribution<double> noise_{0.0, 1.0};
};

// Whether the heat-pump model has a parameter of this name (the benchmarks' name options refuse
// what it has not).
inline bool has_parameter(const std::string& name) {
  const auto& params = plant::find_schema("heat_pump_r32")->parameters;
  for (const plant::ParameterInfo& p : params)
    if (p.name == name) return true;
  return false;
}

// The filters' model: the nominal parameters at the default cell count with what the daemon's
// heat-pump configuration augments (config/demo-heat-pump.json): both coils' air-side UA, the
// compressor's volumetric and isentropic efficiencies, the void-fraction exponent and both
// two-phase heat-transfer factors, all estimated (plant::hp::factor_info says why). Benchmarks
// may change it (estimation_bench --set), and the random walks and consider flags below, before
// they build a filter. Measured on the nominal truth, one hour (constrained EKF): with fouling
// alone augmented the valve-inlet enthalpy, subcooling and cooling capacity were 9-12 sigma off
// (MAPE 0.42 %); with the two-phase closures considered instead of estimated the filter's
// updates pushed the state off the model's slow manifold every cycle (4x the integrator steps)
// and the heat flows 45-128 % off; on the mismatched truth, without the compressor factors the
// suction pressure was gate-rejected in 99.8 % of cycles.
inline plant::ParameterMap& filter_parameters() {
  static plant::ParameterMap p{
      {"augment_fouling", 1},          {"augment_evap_ua_factor", 1},
      {"augment_comp_flow_factor", 1}, {"augment_comp_efficiency_factor", 1},
      {"augment_void_exponent", 1},    {"augment_cond_htc_factor", 1},
      {"augment_evap_htc_factor", 1}};
  return p;
}
// Commissioning (daemon/estimation/commissioning.hpp): for this long after the start the filters
// know the truth's charge (weighed in, sigma 5 g) and calibrate the closures marked for it
// (estimation_bench --commission H; 0, the default: no commissioning).
inline double commissioning_s = 0.0;
inline constexpr double kWeighingSigma = 0.005;  // kg
// The filters hold their parameters this long after the start (est::StatePhases), then ramp
// their gain up as the daemon does by default (estimation_run.hpp, release_s()).
inline constexpr double kSettleS = 600.0;
inline std::map<std::string, double>& process_noise_overrides() {
  static std::map<std::string, double> q;
  return q;
}
// Initial sigma per state instead of the layout's (start_filter; estimation_bench --calibrate).
inline std::map<std::string, double>& initial_std_overrides() {
  static std::map<std::string, double> s;
  return s;
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
  plant::settle(model, u, 600.0, x0);
  for (const auto& s : model.layout().states) {
    const auto it = initial_std_overrides().find(s.name);
    s0.push_back(it != initial_std_overrides().end() ? it->second
                 : s.augmented                       ? s.initial_std
                                                     : 0.2 * s.initial_std);
  }
  filter.reset(x0, s0);
}

}  // namespace hvac_twin::bench
