// Constrained ensemble Kalman filter (stochastic EnKF with perturbed observations), the
// alternative to the EKF for large models: members are integrated without Jacobians, spread
// over a pool of worker threads, each worker with its own model clone and integrator.
//
// Predict: every member integrated over dt with the inputs held and its own draw of the process
// noise held too, as a constant rate w ~ N(0, Q_c / dt) added to its right-hand side (the
// zero-order hold of continuous white noise); then multiplicative inflation of the anomalies.
// A slow state (a random walk) moves by N(0, Q_c dt) as with a kick; a stiff one (a cell
// enthalpy, a wall) keeps only what its own fast dynamics leave of the rate, as a real
// disturbance would. Before, the draw was added as a kick after the integration: every stiff
// state then carried its full N(0, Q_c dt) into the update, where 32 members turned it into
// spurious cross-covariances with the slow states, and the next period's integration had to
// resolve the kick's decay in small steps. Measured (estimation_bench --short --truth all
// --filters enkf, the same draws; nominal / mismatched / biased sensor): evaporator heat flow
// error 166 / 168 / 147 W -> 75 / 93 / 79 W, condenser 55 / 71 / 46 W -> 30 / 68 / 26 W, NEES
// 22.3 / 17.5 / 40.2 -> 9.8 / 10.6 / 4.3, the charge +1.84 / +0.03 / +1.06 % -> +2.38 / +1.41 /
// +1.87 %, the step's median 11-20 % shorter. A member whose integration fails is replaced by a
// copy of another member (counted as a predict failure).
// Update: each available measurement is gated against the ensemble (innovation z - mean h,
// S = ensemble variance of h + R); the accepted ones update every member with the ensemble
// gain K = P_xh (P_hh + R)^-1 and its own perturbed observation. Constrained: each member is then
// projected onto the state constraints (bounds and linear state constraints) by the QP of
// projection.hpp in the metric diag(P) (the ensemble covariance itself is singular when there
// are fewer members than states), and a member that violates an output constraint is drawn
// towards the ensemble mean until it satisfies it.
// A unit's only available point, rejected max_consecutive_rejections times in a row with a
// reading that moved meanwhile, is tested against the initial spread as the EKF does (ekf.hpp):
// the members are spread again about their mean with reset()'s standard deviations, and if the
// point passes the gate there it is fused (a covariance reset); if not, the members are put back
// and the test is repeated later, its interval doubling.
// Estimates: mean and covariance of the ensemble; outputs' mean and standard deviation over the
// members.
//
// Every random draw comes from the member's own generator (seeded from `seed` and the member
// index), and the members are integrated in fixed lanes (`lanes`, contiguous chains of members),
// each with its own model clone and integrator: what a model or an integrator carries from one
// evaluation to the next (the Newton Jacobian kept, member_integrator_options; the heat pump's
// pressure solve, warm-started from its last solution) passes along a lane, in member order,
// from period to period. The pool's threads take whole lanes, so the estimates are the same, to
// the bit, on any number of threads (enkf_test, on the zone and on the heat pump); they depend
// on `lanes`. (Before the lanes, a worker thread carried that state through its own share of the
// members, and one thread and two differed at the integrator's tolerance, which the ensemble
// amplified: valve-inlet enthalpy MAPE 0.119 against 0.134 % in estimation_bench.) Construction
// allocates; nothing after it does.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <memory>
#include <random>
#include <vector>

#include "daemon/estimation/constraint_set.hpp"
#include "daemon/estimation/estimator.hpp"
#include "daemon/estimation/projection.hpp"
#include "daemon/estimation/rejection_streaks.hpp"
#include "daemon/estimation/worker_pool.hpp"
#include "plant_models/core/integrator.hpp"
#include "plant_models/core/model.hpp"

namespace hvac_twin::est {

// The members' integration tolerance: relative 1e-4 (absolute tolerances 100x the model's).
// The ensemble's own sampling error (1/sqrt(32) of its spread) and the process noise it adds
// per period (0.1 kJ/kg on an enthalpy over 5 s) are larger than what a member's integration
// at 1e-4 leaves, and each member then takes far fewer steps. Measured on the heat pump
// (estimation_bench --short --filters enkf --threads 1, BENCH_ENKF_RTOL 1e-6 / 1e-5 / 1e-4):
// the step 37x / 25x / 16x the plain simulation of the period; nominal truth, MAPE of the
// condenser-outlet pressure 0.122 / 0.121 / 0.125 %, evaporator heat flow within 125 / 125 /
// 129 W; mismatched truth (1e-6 / 1e-4) 0.095 / 0.096 % and 128 / 129 W, NIS 1.00 / 1.01.
//
// The members' Newton matrices: a lane keeps one model Jacobian from member to member while
// the state is within 2 initial standard deviations of where it was evaluated
// (plant::IntegratorOptions::jacobian_reuse_sigma; a Newton iteration that fails gets a fresh
// one). A Newton matrix only has to make the iteration converge, not F exact, and the members
// are spread by less than their initial sigma. Measured (estimation_bench --short --truth nominal
// --filters enkf --threads 1, BENCH_ENKF_JACOBIAN_REUSE, two runs each, stop 45): the step 25.0x
// the plain simulation with the filters' 0.05, 21.2-21.3x with 2 (on two threads, four runs
// each on a quiet machine: 13.7-14.8x against 11.2-12.5x; 5 and 1e3: 13.7x and 14.0x).
inline plant::IntegratorOptions member_integrator_options() {
  plant::IntegratorOptions o = filter_integrator_options();
  o.rel_tol = 1e-4;
  o.abs_tol_scale = 100.0;
  o.jacobian_reuse_sigma = 2.0;
  return o;
}

struct EnkfOptions {
  std::size_t members = 32;
  std::size_t threads = 2;  // workers, the calling thread included
  // Fixed chains of members (above); at most `members`. More threads than lanes idle.
  std::size_t lanes = 8;
  double inflation = 1.02;  // multiplies the anomalies at each predict
  double nis_gate = 10.83;
  // Huber's c [innovation sigmas], as the EKF's (est::robust_variance): the perturbed
  // observations and Pyy of a reading beyond it carry the widened variance. 0: off.
  double robust_threshold = 2.0;
  int max_consecutive_rejections = 5;
  double min_measurement_variance = 1e-12;
  bool constrained = true;
  std::uint64_t seed = 1;
  plant::IntegratorOptions integrator =
      member_integrator_options();  // `sensitivities` is forced off
  ProjectionOptions projection;
};

class ConstrainedEnkf final : public Estimator {
 public:
  ConstrainedEnkf(const plant::ContinuousModel& model, std::span<const double> process_noise,
                  std::size_t max_measurements, const EnkfOptions& options);
  ~ConstrainedEnkf() override;

  void reset(std::span<const double> x0, std::span<const double> std0) override;
  // Redraws the members from N(x, P) with their own generators (P may be singular: an LDLT
  // square root), recentred so that their mean is x, then constrained as reset() does; and sets
  // the counters. The generators are not checkpointed, so the run continues statistically, not
  // bit-for-bit.
  bool restore(std::span<const double> x, std::span<const double> P_row_major,
               const EstimatorCounters& counters) override;
  StepStatus predict(std::span<const double> u, double dt) override;
  StepStatus update(std::span<const Measurement> z, std::span<const double> u,
                    std::span<MeasurementReport> reports) override;
  int filter_output_estimates(std::span<const double> u, std::span<double> y,
                              std::span<double> sigma) override;

  [[nodiscard]] const Eigen::VectorXd& state() const override { return mean_; }
  [[nodiscard]] const Eigen::MatrixXd& covariance() const override { return P_; }
  [[nodiscard]] const EstimatorCounters& counters() const override { return counters_; }
  [[nodiscard]] std::size_t num_states() const override { return n_; }
  [[nodiscard]] std::span<const int> active_constraints() const override {
    return {active_.data(), active_count_};
  }
  [[nodiscard]] const std::string& constraint_name(int row) const override {
    return constraints_.name(row);
  }
  [[nodiscard]] const Eigen::MatrixXd& members() const { return X_; }

 private:
  struct Worker;
  struct Lane;
  // fn(worker, lane, member) for every member, each lane's in order, lanes spread over threads.
  template <class Fn>
  void each_member(Fn& fn);
  void statistics();                                 // mean_, anomalies_, P_ from X_
  bool evaluate_outputs(std::span<const double> u);  // Y_ = h(X_); false if a member failed
  void constrain(std::span<const double> u);         // u empty: state constraints only
  double normal(std::size_t member) { return gauss_[member](rng_[member]); }
  // Tests mz against the ensemble's outputs Y_ (ymean_ current): innovation, S, NIS, the verdict.
  void gate(const Measurement& mz, MeasurementReport& rep) const;
  // The lone rejected point i (see above): whether it is fused after a re-spread of the members.
  bool readmit_lone_point(std::size_t i, const Measurement& mz, std::span<const double> u,
                          MeasurementReport& rep);

  EnkfOptions options_;
  std::size_t n_, m_, N_;
  Eigen::VectorXd q_;  // process-noise intensities (variance per second)
  WorkerPool pool_;
  std::vector<std::unique_ptr<Worker>> workers_;
  std::vector<std::unique_ptr<Lane>> lanes_;
  std::vector<std::mt19937_64> rng_;
  std::vector<std::normal_distribution<double>> gauss_;  // per member: no shared state

  Eigen::MatrixXd X_;          // n x N members
  Eigen::MatrixXd anomalies_;  // n x N
  Eigen::VectorXd mean_;
  Eigen::MatrixXd P_;
  Eigen::MatrixXd Y_;     // m x N: every output of every member
  std::vector<char> ok_;  // per member: last evaluation succeeded
  // Update workspace (f = measurements fused this update, at most max_measurements).
  Eigen::MatrixXd Ya_, D_, Pxy_, Pyy_, K_, Kt_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
  Eigen::VectorXd ymean_;
  std::vector<std::size_t> fused_;
  RejectionStreaks streaks_;  // per slot: rejections in a row, the lone-point re-admission
  // The lone-point re-admission: reset()'s standard deviations, and the members with their
  // outputs kept while it is tested.
  Eigen::VectorXd std0_;
  Eigen::MatrixXd X_kept_, Y_kept_;
  std::vector<char> ok_kept_;
  // Constraints.
  ConstraintSet constraints_;
  Eigen::MatrixXd metric_;  // diag(P) as a dense matrix for the projection
  // restore(): the checkpointed P and its pivoted LDLT square root, sized once.
  Eigen::MatrixXd restore_P_;
  Eigen::LDLT<Eigen::MatrixXd> ldlt_;
  Eigen::VectorXd draw_;
  std::vector<int> active_;
  std::size_t active_count_ = 0;
  EstimatorCounters counters_;
};

}  // namespace hvac_twin::est
