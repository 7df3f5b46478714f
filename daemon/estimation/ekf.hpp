// Extended Kalman filter on a ContinuousModel.
//
// Predict: x⁻ = Φ(x, u, dt) by the CVODES integrator, with F = ∂Φ/∂x from forward
// sensitivities (exact to integrator tolerance); P⁻ = F P Fᵀ + Q_d with the trapezoidal
// discretisation Q_d = (F Q_c Fᵀ + Q_c) dt/2 of the continuous random-walk intensities Q_c.
// Update: every available measurement is tested against the prior (innovation ν = z - h(x⁻),
// S = H P⁻ Hᵀ + R, test ratio NIS = ν²/S, gate χ²₁); the accepted ones are fused one scalar at a
// time, linearised at x⁻ (ν_k = z_k - h_k(x⁻) - H_k (x - x⁻)), which equals the batch update for
// diagonal R, with the Joseph form for P. A reading the gate passes but that lies more than
// robust_threshold = c innovation sigmas off (|r| = |ν|/√S > c) is fused with a Huber weight:
// as if its variance were R' = R + S (|r|/c - 1), so its normalised innovation is √(c|r|)
// instead of |r|, and it moves the estimate c/|r| as far (0.63 at 3.2 sigma). (On the
// heat pump a compressor start's outlet-wall reading at 3.2 sigma carried the charge estimate 3
// of its sigmas off in 40 s, and the condenser-outlet wall was then gated out for good:
// tests/data/release_under_load.) The Joseph form with R' keeps P the covariance of that update,
// so P claims no more than the reading gave. After each step the health check requires x and P
// finite and P symmetric positive definite (Cholesky); otherwise the last good (x, P) is restored
// and a numerical reset is counted. A filter that has lost track (most available measurements
// gated out in max_consecutive_rejections updates in a row: its covariance claims a certainty
// the data contradicts) gets its initial covariance back, keeping x, and re-tests the same
// measurements; that is counted as a covariance reset. The points already faulty are held out
// of that re-test and tested against the posterior of the others (a transmitter gone wrong
// would pass against the wide initial covariance alone and drag the estimate with it). A point so
// held out and rejected is tested against the initial covariance 2 x max_consecutive_rejections
// updates later; if it passes there, the estimate may have drifted while the point was out (its
// own information is what kept it right: the heat pump's pressures after a fault on both, when
// the wall temperatures alone, linearised far from the truth, rejected them for good), and a
// reset that tests every point against the initial covariance lets it back in. Was the point
// wrong after all, the filter is lost again a few updates later and resets holding it out; the
// test backs off, its interval doubling, while the point stays wrong. A point
// rejected alone while others are fused is not re-admitted so: from one point a drift and a
// structural mismatch of the model look the same, and a reset every few updates for a biased
// sensor would throw away what the filter knows of the slow states. Except after a reset for
// lost track, until every available point has passed the gate kRecoveredAfterUpdates (12)
// updates in a row: the readings fused in the episode may have left a state that only this point
// sees confidently wrong, and the filter's knowledge is suspect anyway; such a point, rejected
// max_consecutive_rejections times in a row while most others pass, is armed at once
// (lost_track_test: after absurd readings on six of seven points the condenser-outlet wall, right
// again, was otherwise gated out for good, or for most updates, and the discharge pressure stayed
// 3 sigma off; recovery_test). The same while the filter starts (Estimator::set_starting:
// StatePhases' release ramp), when the held parameters' error has been carried by the physical
// states. While recovering or starting, a point fused between two streaks keeps its back-off,
// so each re-test of a point that falls out again comes twice as late. A point that is the only
// available one is: rejected max_consecutive_rejections times in a row, it is tested against
// the initial covariance at once and then with the same back-off, unless its reading has not
// changed once in the streak (a frozen transmitter, for the stuck check). Alone, there is no other
// information to keep, and nothing else would ever end its streak: a zone filter with one
// temperature sensor, overconfident after a cold-start transient, was seen predicting 2 K below
// its sensor for hundreds of updates, its variance levelling off below what the gate needed.
//
// Pure library: no I/O, no clock (dt is passed in). Construction allocates; reset(), predict(),
// update() and output_estimates() never allocate and never throw. One instance per thread.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "daemon/estimation/constraint_set.hpp"
#include "daemon/estimation/estimator.hpp"
#include "daemon/estimation/projection.hpp"
#include "daemon/estimation/rejection_streaks.hpp"
#include "plant_models/core/integrator.hpp"
#include "plant_models/core/model.hpp"

namespace hvac_twin::est {

struct EkfOptions {
  double nis_gate = 10.83;             // χ²₁ at α = 1e-3
  int max_consecutive_rejections = 5;  // a point rejected this many times in a row is "faulty"
  double min_measurement_variance = 1e-12;
  // Huber's c [innovation sigmas]: a reading fused beyond it counts as from a wider noise (see
  // above). 2 keeps 95 % of a consistent filter's readings at full weight. 0: off.
  double robust_threshold = 2.0;
  plant::IntegratorOptions integrator =
      filter_integrator_options();  // `sensitivities` is forced on
  // The constrained update: after the Joseph update, the estimate is projected onto the model's
  // constraints (state bounds, linear state constraints, output constraints linearised at the
  // prior) by the QP of projection.hpp, and the covariance is the PDF truncation
  // (truncation.hpp) of the unconstrained posterior at the constraints active there.
  bool constrained = false;
  ProjectionOptions projection;
  // How deep beyond an active constraint the unconstrained posterior's mean is believed when
  // truncating [sigma along the constraint] (truncation.hpp, "Depth limit"). Infinity: exact.
  double truncation_max_depth = 1.0;
};

using EkfCounters = EstimatorCounters;

class Ekf final : public Estimator {
 public:
  // process_noise: random-walk intensity per state [unit/√s]; max_measurements: most measurements
  // one update() will be offered. Throws std::invalid_argument on size mismatch.
  Ekf(const plant::ContinuousModel& model, std::span<const double> process_noise,
      std::size_t max_measurements, const EkfOptions& options);

  // Sets x and P = diag(std0²), and makes them the last good state.
  void reset(std::span<const double> x0, std::span<const double> std0) override;

  // Sets x, P and the counters from a checkpoint and makes them the last good state; P must also
  // be positive definite (the health check's criterion). Keeps the initial covariance of the
  // last reset(). Restoring the (x, P, counters) of another instance built alike makes the next
  // predict() and update() bit-for-bit those of the original, unless the original reuses a
  // model or output Jacobian from before the checkpoint (jacobian_reuse_sigma > 0 and a state
  // and inputs that stayed within it): the restored one evaluates it afresh, a difference within
  // the reuse distance's linearisation error.
  bool restore(std::span<const double> x, std::span<const double> P_row_major,
               const EstimatorCounters& counters) override;

  StepStatus predict(std::span<const double> u, double dt) override;

  // Tests and fuses `z` (at most max_measurements), writing one report per measurement. Slot i
  // of `z` must be the same sensor every cycle: consecutive rejections are counted per slot.
  StepStatus update(std::span<const Measurement> z, std::span<const double> u,
                    std::span<MeasurementReport> reports) override;

  // Every model output at the current estimate with its standard deviation from the delta
  // method, σ² = H P Hᵀ. The output Jacobian H, here and in update(), is the last one evaluated
  // while no state is further from where it was evaluated than the integrator's
  // jacobian_reuse_sigma (in units of its initial_std, the distance at which the integrator
  // reuses a model Jacobian) and no input further than that in units of its reuse_scale; else it
  // is evaluated at the estimate. In steady operation one H serves many cycles, as one model
  // Jacobian does. The outputs themselves are always evaluated at the estimate.
  int filter_output_estimates(std::span<const double> u, std::span<double> y,
                              std::span<double> sigma) override;

  [[nodiscard]] const Eigen::VectorXd& state() const override { return x_; }
  [[nodiscard]] const Eigen::MatrixXd& covariance() const override { return P_; }
  [[nodiscard]] const Eigen::MatrixXd& transition() const { return F_; }  // F of the last predict
  [[nodiscard]] const EkfCounters& counters() const override { return counters_; }
  // Updates whose posterior the model could not evaluate, stepped back toward the prior
  // (keep_evaluable()). Not in a checkpoint.
  [[nodiscard]] std::uint64_t posterior_step_backs() const { return step_backs_; }
  // Steps whose covariance was positive definite only after its variances were widened by a
  // relative 1e-12 to 1e-6 against rounding (healthy()). Not in a checkpoint.
  [[nodiscard]] std::uint64_t covariance_jitters() const { return jitters_; }
  // Output estimates that reused the update's output Jacobian, and all of them. Not in a
  // checkpoint.
  [[nodiscard]] std::uint64_t output_jacobian_reuses() const { return h_reuses_; }
  [[nodiscard]] std::uint64_t output_estimate_calls() const { return h_calls_; }
  [[nodiscard]] const plant::Integrator& integrator() const { return integrator_; }
  [[nodiscard]] std::size_t num_states() const override { return n_; }
  // Constraint rows active after the last update (constrained mode), and their names.
  [[nodiscard]] std::span<const int> active_constraints() const override {
    return {active_.data(), active_count_};
  }
  [[nodiscard]] const std::string& constraint_name(int row) const override {
    return constraints_->name(row);
  }

 private:
  bool healthy();
  StepStatus finish_step();
  // Tests every measurement of z against the current P; returns how many available ones failed.
  std::size_t gate(std::span<const Measurement> z, std::span<MeasurementReport> reports,
                   std::size_t count, std::size_t& available);
  void fuse(std::size_t output, double innovation_at_prior, double variance);
  // Arms every faulty rejected point (whose reading moved) for readmission_due(), due now: when
  // it is the only available point (the filter is running on its model alone), or in the
  // recovery window after a reset for lost track while most others pass.
  void arm_faulty(std::span<const MeasurementReport> reports, std::size_t count);
  // Whether an armed point whose test is due (streaks_) passes the gate against the
  // initial covariance (a covariance reset is due); advances the back-off of every point tested.
  bool readmission_due(std::span<const Measurement> z, std::span<const MeasurementReport> reports,
                       std::size_t count);
  // After a covariance reset: the held-out (faulty) points tested against the posterior of the
  // others, and fused if they pass.
  void retest_held(std::span<const Measurement> z, std::span<MeasurementReport> reports,
                   std::size_t count);
  void build_constraints();
  void apply_constraints();
  // A posterior the model cannot evaluate (inside every state bound, outside a property table's
  // domain at the pressures it implies) would fail every prediction after it, until a restart.
  // Steps back toward the prior, halving the step up to kMaxStepBacks times (the prior itself
  // last), until the model's right-hand side and outputs evaluate; the covariance the matching
  // convex combination of posterior and prior, which is at least that of the partial update.
  void keep_evaluable(std::span<const double> u);
  static constexpr int kMaxStepBacks = 6;

  const plant::ContinuousModel& model_;
  EkfOptions options_;
  std::size_t n_, m_;
  plant::Integrator integrator_;

  Eigen::VectorXd x_, x_prior_, x_good_;
  Eigen::MatrixXd P_, P_good_, P_initial_, F_, tmp_;
  Eigen::VectorXd qc_;                    // Qc's diagonal: process-noise intensities squared
  Eigen::MatrixXd P_prior_;               // P before this update's fusion (after a reset: P0)
  Eigen::VectorXd x_try_, xdot_, y_try_;  // keep_evaluable()'s scratch
  std::uint64_t step_backs_ = 0;
  std::uint64_t jitters_ = 0;  // healthy()'s widenings against rounding
  Eigen::MatrixXd H_;          // m x n output Jacobian, evaluated at (h_x_, h_u_)
  // Where H_ was evaluated: the state, the inputs, whether it holds (reset() and restore() end
  // it); the distance's unit per state (its initial_std) and per input (its reuse_scale).
  Eigen::VectorXd h_x_, h_scale_;
  std::vector<double> h_u_, h_u_scale_;
  bool h_valid_ = false;
  std::uint64_t h_reuses_ = 0, h_calls_ = 0;
  // Whether H_ holds at (x_, u): evaluated within the integrator's jacobian_reuse_sigma of them.
  [[nodiscard]] bool output_jacobian_holds(std::span<const double> u) const;
  // The outputs at x_ into y, and H_ evaluated there unless it holds (see above).
  int outputs_with_jacobian(std::span<const double> u, std::span<double> y);
  Eigen::VectorXd y_;  // h(x⁻)
  Eigen::VectorXd ph_, k_, bh_;
  Eigen::MatrixXd b_;
  Eigen::VectorXd max_var_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
  // Per measurement slot (update() keeps the order): rejections in a row, and the re-admission
  // schedule. A slot is armed when a covariance reset held the point out and its re-test failed,
  // or when it was the only available point, rejected max_consecutive_rejections times in a row
  // with a reading that moved: tested against the initial covariance 2 x
  // max_consecutive_rejections rejections later, the interval doubling after each test.
  RejectionStreaks streaks_;
  int lost_updates_ = 0;  // consecutive updates with most points gated out
  // After a reset for lost track, until every available point has passed the gate
  // kRecoveredAfterUpdates updates in a row: a point rejected while most others pass is armed at
  // once (see the top of this file, "Re-admission").
  static constexpr int kRecoveredAfterUpdates = 12;
  bool recovering_ = false;
  int clean_updates_ = 0;      // updates in a row, while recovering, with every available point in
  std::vector<int> held_;      // per slot, after a reset: its rejections in a row before, or -1
  std::vector<double> x_buf_;  // contiguous scratch for the integrator

  // Constrained mode.
  std::unique_ptr<ConstraintSet> constraints_;
  Eigen::VectorXd x_unc_, row_, work_;
  // The projection with consider states held: P without their rows and columns, the
  // constraints with their terms moved to the bounds.
  Eigen::MatrixXd P_free_, A_free_;
  Eigen::VectorXd b_free_;
  // A row whose variance in the estimated states is below this share of its whole variance is
  // left out of the projection (apply_constraints).
  static constexpr double kMinFreeShare = 1e-6;
  std::unique_ptr<ConstrainedProjection> projection_;
  std::vector<int> active_;
  std::size_t active_count_ = 0;
  EkfCounters counters_;
};

}  // namespace hvac_twin::est
