// What the runtime needs of an estimator, whichever it is: the (constrained) EKF or the
// constrained ensemble Kalman filter. Selected by the configuration (estimator.type).
//
// Pure library: time is passed in. After construction no call allocates or throws. One thread
// drives an instance (the EnKF fans its members out to its own workers internally).
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "plant_models/core/integrator.hpp"
#include "plant_models/core/model_info.hpp"

namespace hvac_twin::est {

// The filters' integrator options: a prediction that needs more than kMaxPredictSteps internal
// steps fails (the filter keeps x and inflates P, StepStatus::kModelError) instead of grinding
// on. A heat-pump period of 5 s takes 20-250 steps; a prediction from a state the model cannot
// resolve ran to the integrator's general limit of 20000 steps, 40 s of one core per failed
// prediction at 12 cells, longer than the daemon's hang timeout.
inline constexpr long kMaxPredictSteps = 1000;
// F under sensitivity error control at a loose relative tolerance (0.1). Riding on the steps the
// state alone needs, F was exact on transients (1e-4 of a tight reference) but not in steady
// operation, where the state takes steps of seconds, longer than F's fast modes: measured on the
// heat pump at 12 cells (race_bench, steady-state row), 3 steps per 5 s period, F 30 % off and the
// outputs' predicted sigmas 40 %; under error control 1e-4 and 5e-5, for 7 % more time per step
// on the benchmark's transients, and 24 steps instead of 3 in steady operation
// (filter_transition_test checks F there).
//
// F as a product of matrix exponentials (SensitivityMethod::kExponential): CVODES
// integrates the state alone and F = prod exp((J_start + J_end)/2 dt) over segments of its
// trajectory, each lasting while no state moves more than the Jacobian-reuse distance below.
// Exact on the state's own steps in steady operation (4e-7 of the reference in 3 steps where the
// direct solve under error control is 0.006 off in 24), and in race_bench --short the
// constrained-EKF step 1.5x the plain simulation against 3.9x. It waited on a filter question:
// with an exact F (either way) the constrained EKF stayed 21-29 g off after a glitch fused with
// the gate open, its truncated sigma 0.7 g; the truncation's depth limit (truncation.hpp) ended
// that. The plain EKF recovers from that glitch more slowly with an exact F
// (constraints_heat_pump_test says how much); the direct solve's 0.1 error had hidden it.
//
// One model Jacobian serves CVODES's Newton matrix and F's segments while no state has moved by
// more than 0.1 of its initial sigma (1 kJ/kg on an enthalpy, 0.2 K on a wall) from where it
// was evaluated, and is kept across periods while the inputs stay as close (IntegratorOptions).
// With F as matrix exponentials each segment takes the mean of the Jacobians at its two ends (the
// trapezoidal rule), so a longer segment costs F little. Measured at stop 48 on the heat pump
// at 12 cells, 0.05 (the value from stop 43 to 47) / 0.1 / 0.15:
//  - race_bench --short --jacobian-reuse D (5 s): the constrained-EKF step 4.63 / 3.46 / 3.20 ms
//    median, p99 34 / 32 / 26 ms; F's worst error against the tight reference over the 19
//    checked periods 6e-3 / 1e-2 / 2e-2 (Frobenius), the outputs' predicted sigma 1e-2 / 4e-2 /
//    2e-1 relative (F's own relative tolerance is 0.1: 0.15 oversteps it);
//  - the same at --period 1 --every 120: the step 2.46 / 1.81 / 1.82 ms median, p99 12.2 / 9.4 /
//    7.6 ms; the outputs' sigma 1e-2 / 4e-2 / 3e-2;
//  - estimation_bench --short --truth all --filters cekf (BENCH_JACOBIAN_REUSE=D, 5 s): the step
//    19.7 / 15.4 / 13.1 ms median; the charge +3.58 / +3.63 / +3.63 % (nominal), +3.45 / +3.35 /
//    +3.50 % (mismatched), +2.43 / +2.58 / +2.45 % (biased sensor); h_vi MAPE 0.067 / 0.061 /
//    0.063 %, 0.072 / 0.081 / 0.086 %, 0.078 / 0.075 / 0.073 %; NIS within 0.01, NEES within
//    0.3, the gate shares within 0.3 points, the shares within 2 sigma within 2 points.
// (Before F was made of exponentials, with kDirect's per-step solves on a lagged Jacobian, 0.1
// had moved the mismatched truth's h_vi MAPE 0.088 -> 0.123 %; that is why 0.05 was chosen.)
inline constexpr double kFilterJacobianReuseSigma = 0.1;
//
// The state at a relative tolerance of 1e-5, absolute tolerances 10x the model's (which are
// meant for 1e-6): the integration's error belongs well inside the process noise the filter
// adds for the model's own error in a period, and 1e-6 bought nothing the filter can use.
// Measured on the heat pump at 12 cells (race_bench --short --rel-tol R, the x err column: the
// filter's state at the period's end against a reference at 1e-10, in units of the period's
// process-noise sigma, worst state and worst of 19 periods checked: transients, the largest
// update, steady state), R = 1e-6 / 1e-5 / 1e-4: 0.05 / 0.38 / 3.3 sigma, with the
// constrained-EKF step 8.7 / 5.8 / 5.1 ms median (BDF steps per period 35 / 19 / 11);
// estimation_bench --short --truth all --filters cekf the same figures to the last printed
// digit at 1e-5 but one (biased sensor: charge +2.80 -> +2.74 %), the step's median 25.3 -> 19.8
// ms. 1e-4 moved them too, but little (mismatched: h_vi MAPE 0.073 -> 0.079 %, charge +3.31 ->
// +3.18 %); at 3 sigma per period its error is as large as the model error the filter allows
// for, so not taken. F is not affected: the exponentials' segments follow the state's motion.
inline constexpr double kFilterRelTol = 1e-5;
inline plant::IntegratorOptions filter_integrator_options() {
  plant::IntegratorOptions o;
  o.rel_tol = kFilterRelTol;
  o.abs_tol_scale = kFilterRelTol / 1e-6;
  o.max_steps = kMaxPredictSteps;
  o.sensitivity_error_control = true;
  o.sensitivity_rel_tol = 0.1;
  o.jacobian_reuse_sigma = kFilterJacobianReuseSigma;
  o.sensitivity_method = plant::SensitivityMethod::kExponential;
  return o;
}

// One scalar measurement offered to update().
struct Measurement {
  std::size_t output = 0;  // index of the model output it measures
  double value = 0.0;      // [output unit]
  double variance = 0.0;   // R [output unit²]
  bool available = false;  // GOOD quality and finite value; otherwise it is only reported
};

// What happened to one measurement in update(); published per point.
struct MeasurementReport {
  double predicted = 0.0;   // h(x⁻) (the ensemble mean of h for the EnKF); for every measurement
                            // of an existing output, available or not
  double innovation = 0.0;  // z - predicted
  double innovation_variance = 0.0;  // S = H P⁻ Hᵀ + R (ensemble variance of h + R)
  double test_ratio = 0.0;           // ν² / S
  bool available = false;
  bool fused = false;
  bool rejected = false;  // failed the gate
  bool faulty = false;    // rejected max_consecutive_rejections times in a row
};

// The variance a reading the gate let in is fused with (both filters): its own, r, within c
// innovation sigmas; beyond, Huber's weight, as if it were r + S (|ν|/√S / c - 1): the reading
// moves the estimate c √S/|ν| as far, and the covariance keeps only what it gave. c <= 0: off.
inline double robust_variance(double r, const MeasurementReport& rep, double c) {
  if (!(c > 0.0) || !(rep.test_ratio > c * c)) return r;
  return r + rep.innovation_variance * (std::sqrt(rep.test_ratio) / c - 1.0);
}

enum class StepStatus : std::uint8_t {
  kOk,
  kModelError,      // the model failed (predict: x kept, P inflated; update: nothing fused)
  kNumericalReset,  // health check failed; last good state restored
};

struct EstimatorCounters {
  std::uint64_t predicts = 0;
  std::uint64_t updates = 0;
  std::uint64_t fused = 0;
  std::uint64_t gate_rejections = 0;
  std::uint64_t predict_failures = 0;  // EnKF: members whose integration failed
  std::uint64_t numerical_resets = 0;
  std::uint64_t covariance_resets = 0;
  std::uint64_t constrained_updates = 0;  // updates in which a constraint was active
  std::uint64_t projection_failures = 0;  // QP iteration cap or infeasible constraints
};

class Estimator {
 public:
  virtual ~Estimator() = default;
  Estimator() = default;
  Estimator(const Estimator&) = delete;
  Estimator& operator=(const Estimator&) = delete;

  // Sets the state and P = diag(std0²) (the EnKF draws its members from that Gaussian).
  virtual void reset(std::span<const double> x0, std::span<const double> std0) = 0;
  // Resumes from a checkpoint (start-up, after reset(), which sets the covariance a filter that
  // lost track returns to): the estimate x, its covariance P (row-major n x n) and the counters.
  // Returns false and changes nothing unless x has n entries and P n x n, every value is finite
  // and P is symmetric (relative 1e-9) with a non-negative diagonal; an implementation may
  // refuse more (the EKF: P not positive definite). Per-point rejection runs start afresh.
  virtual bool restore(std::span<const double> x, std::span<const double> P_row_major,
                       const EstimatorCounters& counters) = 0;
  virtual StepStatus predict(std::span<const double> u, double dt) = 0;
  // Tests and fuses z, one report per measurement; slot i of z is the same sensor every cycle.
  virtual StepStatus update(std::span<const Measurement> z, std::span<const double> u,
                            std::span<MeasurementReport> reports) = 0;
  // Every model output at the estimate with its standard deviation: the filter's own (its
  // covariance, or its ensemble's spread) and the model's structural error in that output
  // (SignalInfo::model_error, model_error_rel) in quadrature. filter_sigma, when given, receives
  // the filter's own part alone: what a comparison of the estimate with itself at another time
  // needs (the leak detector's charge against its reference), where a structural error that
  // does not change cancels.
  int output_estimates(std::span<const double> u, std::span<double> y, std::span<double> sigma,
                       std::span<double> filter_sigma = {}) {
    const int status = filter_output_estimates(u, y, sigma);
    if (status != 0) return status;
    for (std::size_t o = 0; o < filter_sigma.size() && o < sigma.size(); ++o)
      filter_sigma[o] = sigma[o];
    for (std::size_t o = 0; o < model_error_.size() && o < y.size() && o < sigma.size(); ++o)
      if (model_error_[o] > 0.0 || model_error_rel_[o] > 0.0)
        sigma[o] = std::hypot(sigma[o], model_error_[o], model_error_rel_[o] * std::abs(y[o]));
    return status;
  }

  [[nodiscard]] virtual const Eigen::VectorXd& state() const = 0;
  [[nodiscard]] virtual const Eigen::MatrixXd& covariance() const = 0;
  [[nodiscard]] virtual const EstimatorCounters& counters() const = 0;
  [[nodiscard]] virtual std::size_t num_states() const = 0;
  // Constraint rows active after the last update, and their names.
  [[nodiscard]] virtual std::span<const int> active_constraints() const = 0;
  [[nodiscard]] virtual const std::string& constraint_name(int row) const = 0;

  // "Consider" states (Schmidt-Kalman): uncertain, their covariance propagated with the rest,
  // but no update moves them, so their uncertainty reaches every estimate it affects without
  // the data pulling them where they cannot be told apart from other states. Initially the
  // model layout's StateInfo::consider; the caller may switch a state at any time (a
  // commissioning period estimates what is otherwise considered). No allocation.
  void set_consider(std::size_t state, bool consider) {
    if (state < consider_.size()) consider_[state] = consider ? 1 : 0;
  }
  [[nodiscard]] bool considered(std::size_t state) const {
    return state < consider_.size() && consider_[state] != 0;
  }
  // Partial update (Brink, "Partial-update Schmidt-Kalman filter", JGCD 2017): an update moves
  // an estimated state by `weight` (0 to 1, clamped) times the Kalman step; its covariance is
  // that of the estimator so run (the EKF's Joseph form holds for any gain). 1 by default; a
  // consider state is not moved whatever its weight. StatePhases ramps the augmented states'
  // weight from 0 to 1 after the settling hold, so that a parameter released with its whole
  // prior is not thrown, in one update linearised at the prior, to where its sigma collapses.
  // No allocation.
  void set_gain_weight(std::size_t state, double weight) {
    if (state < gain_weight_.size()) gain_weight_[state] = std::clamp(weight, 0.0, 1.0);
  }
  [[nodiscard]] double gain_weight(std::size_t state) const {
    return state < gain_weight_.size() ? gain_weight_[state] : 1.0;
  }

  // Whether the filter is starting: its slow states released from their hold but not yet at
  // full gain (StatePhases sets it during the release ramp, not the hold, when the held
  // parameters could not fit the point anyway). The EKF then treats a point rejected while
  // most others pass as it does after a reset for lost track (ekf.hpp, "Re-admission"): while
  // the held parameters are wrong the physical states absorb their error, and a sensor that only
  // sees the state they carried off is gated out; nothing else would let it back in once the
  // parameters are free. The EnKF ignores it. No allocation.
  void set_starting(bool starting) { starting_ = starting; }
  [[nodiscard]] bool starting() const { return starting_; }

 protected:
  // The filter's own estimate of every output and its standard deviation, without the model's
  // structural error (output_estimates adds it).
  virtual int filter_output_estimates(std::span<const double> u, std::span<double> y,
                                      std::span<double> sigma) = 0;

  // Sizes the consider flags and the outputs' structural errors from the model's layout
  // (constructors; allocates).
  void init_consider(const plant::ModelLayout& layout) {
    consider_.assign(layout.states.size(), 0);
    gain_weight_.assign(layout.states.size(), 1.0);
    for (std::size_t i = 0; i < layout.states.size(); ++i)
      consider_[i] = layout.states[i].consider ? 1 : 0;
    model_error_.clear();
    model_error_rel_.clear();
    for (const auto& o : layout.outputs) {
      model_error_.push_back(o.model_error);
      model_error_rel_.push_back(o.model_error_rel);
    }
  }
  std::vector<char> consider_;
  std::vector<double> gain_weight_;                    // per state, 0 to 1 (set_gain_weight)
  bool starting_ = false;                              // set_starting()
  std::vector<double> model_error_, model_error_rel_;  // per output

  // The checks every restore() makes: sizes, finiteness, symmetry, non-negative variances. A
  // checkpoint has already been checked by its loader; this guards every other caller.
  [[nodiscard]] static bool restorable(std::span<const double> x, std::span<const double> P,
                                       std::size_t n) {
    if (x.size() != n || P.size() != n * n) return false;
    for (const double v : x)
      if (!std::isfinite(v)) return false;
    for (std::size_t r = 0; r < n; ++r) {
      if (!(P[r * n + r] >= 0.0)) return false;
      for (std::size_t c = 0; c < n; ++c) {
        const double a = P[r * n + c], b = P[c * n + r];
        if (!std::isfinite(a) || !(std::abs(a - b) <= 1e-9 * std::max(std::abs(a), std::abs(b))))
          return false;
      }
    }
    return true;
  }
};

}  // namespace hvac_twin::est
