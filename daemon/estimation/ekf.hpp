// Extended Kalman filter on a ContinuousModel.
//
// Predict: x⁻ = Φ(x, u, dt) by the CVODES integrator, with F = ∂Φ/∂x from forward
// sensitivities (exact to integrator tolerance); P⁻ = F P Fᵀ + Q_d with the trapezoidal
// discretisation Q_d = (F Q_c Fᵀ + Q_c) dt/2 of the continuous random-walk intensities Q_c.
// Update: every available measurement is tested against the prior (innovation ν = z - h(x⁻),
// S = H P⁻ Hᵀ + R, test ratio NIS = ν²/S, gate χ²₁); the accepted ones are fused one scalar at a
// time, linearised at x⁻ (ν_k = z_k - h_k(x⁻) - H_k (x - x⁻)), which equals the batch update for
// diagonal R, with the Joseph form for P. After each step the health check requires x and P
// finite and P symmetric positive definite (Cholesky); otherwise the last good (x, P) is restored
// and a numerical reset is counted. A filter that has lost track (most available measurements
// gated out in max_consecutive_rejections updates in a row: its covariance claims a certainty
// the data contradicts) gets its initial covariance back, keeping x, and re-tests the same
// measurements; that is counted as a covariance reset.
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

#include "daemon/estimation/projection.hpp"
#include "plant_models/core/integrator.hpp"
#include "plant_models/core/model.hpp"

namespace hvac_twin::est {

struct EkfOptions {
  double nis_gate = 10.83;             // χ²₁ at α = 1e-3
  int max_consecutive_rejections = 5;  // a point rejected this many times in a row is "faulty"
  double min_measurement_variance = 1e-12;
  plant::IntegratorOptions integrator;  // `sensitivities` is forced on
  // The constrained update: after the Joseph update, the estimate is projected onto the model's
  // constraints (state bounds, linear state constraints, output constraints linearised at the
  // prior) by the QP of projection.hpp, and the covariance is the PDF truncation
  // (truncation.hpp) of the unconstrained posterior at the constraints active there.
  bool constrained = false;
  ProjectionOptions projection;
};

// One scalar measurement offered to update().
struct Measurement {
  std::size_t output = 0;  // index of the model output it measures
  double value = 0.0;      // [output unit]
  double variance = 0.0;   // R [output unit²]
  bool available = false;  // GOOD quality and finite value; otherwise it is only reported
};

// What happened to one measurement in update(); published per point.
struct MeasurementReport {
  double predicted = 0.0;            // h(x⁻)
  double innovation = 0.0;           // z - h(x⁻)
  double innovation_variance = 0.0;  // H P⁻ Hᵀ + R
  double test_ratio = 0.0;           // ν² / S
  bool available = false;
  bool fused = false;
  bool rejected = false;  // failed the gate
  bool faulty = false;    // rejected max_consecutive_rejections times in a row
};

enum class StepStatus : std::uint8_t {
  kOk,
  kModelError,      // the integrator or the output function failed: predict keeps x and
                    // inflates P by Q_c dt; update fuses nothing
  kNumericalReset,  // health check failed; last good (x, P) restored
};

struct EkfCounters {
  std::uint64_t predicts = 0;
  std::uint64_t updates = 0;
  std::uint64_t fused = 0;
  std::uint64_t gate_rejections = 0;
  std::uint64_t predict_failures = 0;
  std::uint64_t numerical_resets = 0;
  std::uint64_t covariance_resets = 0;
  std::uint64_t constrained_updates = 0;  // updates in which a constraint was active
  std::uint64_t projection_failures = 0;  // QP iteration cap or infeasible constraints
};

class Ekf {
 public:
  // process_noise: random-walk intensity per state [unit/√s]; max_measurements: most measurements
  // one update() will be offered. Throws std::invalid_argument on size mismatch.
  Ekf(const plant::ContinuousModel& model, std::span<const double> process_noise,
      std::size_t max_measurements, const EkfOptions& options);

  // Sets x and P = diag(std0²), and makes them the last good state.
  void reset(std::span<const double> x0, std::span<const double> std0);

  StepStatus predict(std::span<const double> u, double dt);

  // Tests and fuses `z` (at most max_measurements), writing one report per measurement. Slot i
  // of `z` must be the same sensor every cycle: consecutive rejections are counted per slot.
  StepStatus update(std::span<const Measurement> z, std::span<const double> u,
                    std::span<MeasurementReport> reports);

  // Every model output at the current estimate with its standard deviation from the delta
  // method, σ² = H P Hᵀ.
  int output_estimates(std::span<const double> u, std::span<double> y, std::span<double> sigma);

  [[nodiscard]] const Eigen::VectorXd& state() const { return x_; }
  [[nodiscard]] const Eigen::MatrixXd& covariance() const { return P_; }
  [[nodiscard]] const Eigen::MatrixXd& transition() const { return F_; }  // F of the last predict
  [[nodiscard]] const EkfCounters& counters() const { return counters_; }
  [[nodiscard]] const plant::Integrator& integrator() const { return integrator_; }
  [[nodiscard]] std::size_t num_states() const { return n_; }
  // Constraint rows active after the last update (constrained mode), and their names.
  [[nodiscard]] std::span<const int> active_constraints() const {
    return {active_.data(), active_count_};
  }
  [[nodiscard]] const std::string& constraint_name(int row) const {
    return row_names_[static_cast<std::size_t>(row)];
  }

 private:
  bool healthy();
  StepStatus finish_step();
  // Tests every measurement of z against the current P; returns how many available ones failed.
  std::size_t gate(std::span<const Measurement> z, std::span<MeasurementReport> reports,
                   std::size_t count, std::size_t& available);
  void fuse(std::size_t output, double innovation_at_prior, double variance);
  void build_constraints();
  void apply_constraints();

  const plant::ContinuousModel& model_;
  EkfOptions options_;
  std::size_t n_, m_;
  plant::Integrator integrator_;

  Eigen::VectorXd x_, x_prior_, x_good_;
  Eigen::MatrixXd P_, P_good_, P_initial_, F_, Qc_, Qd_, tmp_;
  Eigen::MatrixXd H_;  // m x n output Jacobian at x⁻
  Eigen::VectorXd y_;  // h(x⁻)
  Eigen::VectorXd ph_, k_, bh_;
  Eigen::MatrixXd b_;
  Eigen::VectorXd max_var_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
  std::vector<int> consecutive_rejections_;  // per measurement slot (update() keeps the order)
  int lost_updates_ = 0;                     // consecutive updates with most points gated out
  std::vector<double> x_buf_;                // contiguous scratch for the integrator

  // Constrained mode: rows [0, static_rows_) from the state bounds and state constraints, then
  // one row per output constraint, refilled each update.
  struct OutputRow {
    std::vector<std::pair<std::size_t, double>> terms;
    double bound = 0.0;
  };
  Eigen::MatrixXd A_;
  Eigen::VectorXd bound_, scale_, x_unc_, row_, work_;
  std::size_t static_rows_ = 0;
  std::vector<OutputRow> output_rows_;
  std::vector<std::string> row_names_;
  std::unique_ptr<ConstrainedProjection> projection_;
  std::vector<int> active_;
  std::size_t active_count_ = 0;
  EkfCounters counters_;
};

}  // namespace hvac_twin::est
