#include "daemon/estimation/ekf.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "daemon/estimation/truncation.hpp"
#include "plant_models/core/reuse_distance.hpp"

namespace hvac_twin::est {
namespace {

plant::IntegratorOptions with_sensitivities(plant::IntegratorOptions o) {
  o.sensitivities = true;
  return o;
}

std::span<double> span_of(Eigen::VectorXd& v) {
  return {v.data(), static_cast<std::size_t>(v.size())};
}
std::span<double> span_of(Eigen::MatrixXd& m) {
  return {m.data(), static_cast<std::size_t>(m.size())};
}
std::span<const double> span_of(const Eigen::VectorXd& v) {
  return {v.data(), static_cast<std::size_t>(v.size())};
}

}  // namespace

Ekf::Ekf(const plant::ContinuousModel& model, std::span<const double> process_noise,
         std::size_t max_measurements, const EkfOptions& options)
    : model_(model),
      options_(options),
      n_(model.num_states()),
      m_(model.num_outputs()),
      integrator_(model, with_sensitivities(options.integrator)),
      // Sized here, not move-assigned later: LLT(size) leaves its ComputationInfo unset, and
      // copying that indeterminate enum is undefined behaviour (UBSan: invalid enum load).
      llt_(static_cast<Eigen::Index>(model.num_states())) {
  if (process_noise.size() != n_)
    throw std::invalid_argument("EKF: process noise must have one entry per state");
  const auto n = static_cast<Eigen::Index>(n_), m = static_cast<Eigen::Index>(m_);
  x_ = x_prior_ = x_good_ = x_try_ = xdot_ = Eigen::VectorXd::Zero(n);
  P_ = P_good_ = P_initial_ = P_prior_ = F_ = tmp_ = b_ = Eigen::MatrixXd::Zero(n, n);
  qc_ = Eigen::VectorXd::Zero(n);
  y_try_ = Eigen::VectorXd::Zero(m);
  H_ = Eigen::MatrixXd::Zero(m, n);
  y_ = Eigen::VectorXd::Zero(m);
  h_x_ = h_scale_ = Eigen::VectorXd::Zero(n);
  h_u_.assign(model.num_inputs(), 0.0);
  for (const auto& in : model.layout().inputs)
    h_u_scale_.push_back(std::abs(in.reuse_scale));
  ph_ = k_ = bh_ = Eigen::VectorXd::Zero(n);
  max_var_ = Eigen::VectorXd::Constant(n, std::numeric_limits<double>::infinity());
  const auto& states = model.layout().states;
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto& s = states[static_cast<std::size_t>(i)];
    qc_(i) =
        process_noise[static_cast<std::size_t>(i)] * process_noise[static_cast<std::size_t>(i)];
    // A standard deviation wider than the state's whole physical range carries no information
    // and only invites overflow: clamp the variance there.
    const double width = s.max - s.min;
    if (std::isfinite(width)) max_var_(i) = width * width;
    h_scale_(i) = std::abs(s.initial_std);
  }
  streaks_.resize(max_measurements);
  held_.assign(max_measurements, 0);
  x_buf_.assign(n_, 0.0);
  init_consider(model.layout());
  if (options_.constrained) build_constraints();
}

void Ekf::build_constraints() {
  constraints_ = std::make_unique<ConstraintSet>(model_.layout());
  x_unc_ = row_ = work_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n_));
  projection_ =
      std::make_unique<ConstrainedProjection>(n_, constraints_->rows(), options_.projection);
  active_.assign(options_.projection.max_active, -1);
  P_free_ = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(n_), static_cast<Eigen::Index>(n_));
  A_free_ = constraints_->A();
  b_free_ = constraints_->b();
}

void Ekf::apply_constraints() {
  // Output constraints, linearised at the prior: g(x) ~ g(x-) + G (x - x-) <= bound.
  constraints_->linearise_outputs(x_prior_, y_, H_);
  x_unc_ = x_;
  const ConstraintSet& c = *constraints_;
  // Nor does the projection move a consider state: it projects the other states, in the metric
  // of their covariance, onto the constraints with the consider states at their values.
  P_free_ = P_;
  A_free_ = c.A();
  b_free_ = c.b();
  bool any_consider = false;
  for (std::size_t i = 0; i < n_; ++i) {
    if (consider_[i] == 0) continue;
    any_consider = true;
    const auto k = static_cast<Eigen::Index>(i);
    P_free_.row(k).setZero();
    P_free_.col(k).setZero();
    b_free_ -= A_free_.col(k) * x_(k);
    A_free_.col(k).setZero();
  }
  // A row the estimated states can barely move (its variance almost all in consider states: a
  // bound on a held state, an output the held states set) is not this update's to enforce.
  // Projected anyway, it moved what little it could by any amount: a pressure constraint the
  // held refrigerant circuit violated at rest drove the zone air temperature to -1e29 K.
  if (any_consider) {
    for (Eigen::Index r = 0; r < static_cast<Eigen::Index>(c.rows()); ++r) {
      if (A_free_.row(r) == c.A().row(r)) continue;  // no consider term
      row_ = c.A().row(r).transpose();
      work_.noalias() = P_ * row_;
      const double full = row_.dot(work_);
      row_ = A_free_.row(r).transpose();
      work_.noalias() = P_free_ * row_;
      if (row_.dot(work_) > kMinFreeShare * full) continue;
      A_free_.row(r).setZero();
      b_free_(r) = std::max(b_free_(r), 0.0);  // off: 0 <= b
    }
  }
  const ProjectionResult result =
      projection_->solve(x_, P_free_, A_free_, b_free_, c.scale(), c.rows());
  if (!result.converged) ++counters_.projection_failures;
  const auto active = projection_->active();
  active_count_ = active.size();
  std::copy(active.begin(), active.end(), active_.begin());
  if (active_count_ == 0) return;
  ++counters_.constrained_updates;
  // The covariance: the unconstrained posterior truncated at each active constraint in turn
  // (on the states the projection moves).
  for (const int r : active) {
    row_ = A_free_.row(r).transpose();
    truncate_gaussian(x_unc_, P_, row_, b_free_(r), work_, options_.truncation_max_depth);
  }
}

void Ekf::reset(std::span<const double> x0, std::span<const double> std0) {
  P_.setZero();
  for (std::size_t i = 0; i < n_; ++i) {
    x_(static_cast<Eigen::Index>(i)) = x0[i];
    P_(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(i)) = std0[i] * std0[i];
  }
  x_good_ = x_;
  P_good_ = P_;
  P_initial_ = P_;
  lost_updates_ = 0;
  recovering_ = false;
  clean_updates_ = 0;
  streaks_.clear();
  h_valid_ = false;
  integrator_.forget_jacobian();
}

bool Ekf::restore(std::span<const double> x, std::span<const double> P_row_major,
                  const EstimatorCounters& counters) {
  if (!restorable(x, P_row_major, n_)) return false;
  const auto n = static_cast<Eigen::Index>(n_);
  // Checked in scratch first so that a refused P changes nothing.
  for (Eigen::Index r = 0; r < n; ++r)
    for (Eigen::Index c = 0; c < n; ++c)
      tmp_(r, c) = P_row_major[static_cast<std::size_t>(r * n + c)];
  llt_.compute(tmp_);
  if (llt_.info() != Eigen::Success) return false;
  P_ = tmp_;
  for (Eigen::Index i = 0; i < n; ++i)
    x_(i) = x[static_cast<std::size_t>(i)];
  x_good_ = x_;
  P_good_ = P_;
  counters_ = counters;
  lost_updates_ = 0;
  recovering_ = false;
  clean_updates_ = 0;
  streaks_.clear();
  active_count_ = 0;
  h_valid_ = false;
  integrator_.forget_jacobian();
  return true;
}

StepStatus Ekf::predict(std::span<const double> u, double dt) {
  ++counters_.predicts;
  std::copy(x_.data(), x_.data() + n_, x_buf_.begin());
  const plant::IntegrationResult r = integrator_.step(x_buf_, u, dt, span_of(F_));
  if (!r.ok()) {
    // Keep the estimate, admit we know less: add the process noise of the period.
    ++counters_.predict_failures;
    P_.diagonal() += dt * qc_;
    const StepStatus health = finish_step();
    return health == StepStatus::kOk ? StepStatus::kModelError : health;
  }
  std::copy(x_buf_.begin(), x_buf_.end(), x_.data());
  // P = F P Fᵀ + Q_d with the trapezoidal Q_d = (dt/2) (F Qc Fᵀ + Qc), as
  // F (P + (dt/2) Qc) Fᵀ + (dt/2) Qc: two products of n x n matrices instead of four.
  P_.diagonal() += (0.5 * dt) * qc_;
  tmp_.noalias() = F_ * P_;
  P_.noalias() = tmp_ * F_.transpose();
  P_.diagonal() += (0.5 * dt) * qc_;
  return finish_step();
}

StepStatus Ekf::update(std::span<const Measurement> z, std::span<const double> u,
                       std::span<MeasurementReport> reports) {
  ++counters_.updates;
  const std::size_t count = std::min({z.size(), reports.size(), streaks_.size()});
  for (std::size_t i = 0; i < count; ++i)
    reports[i] = MeasurementReport{};
  if (outputs_with_jacobian(u, span_of(y_)) != plant::kModelOk) return StepStatus::kModelError;
  x_prior_ = x_;

  // Test every measurement against the prior, as the published innovations are.
  std::size_t available = 0;
  const std::size_t rejected = gate(z, reports, count, available);
  lost_updates_ = available >= 2 && 2 * rejected > available ? lost_updates_ + 1 : 0;
  const bool lost = lost_updates_ >= options_.max_consecutive_rejections;
  // Arming a faulty point for a test against the initial covariance: the only available one, or,
  // in the updates after a reset for lost track, any point rejected while most others pass.
  if (recovering_) {
    clean_updates_ = rejected == 0 && available > 0 ? clean_updates_ + 1 : 0;
    if (clean_updates_ >= kRecoveredAfterUpdates) recovering_ = false;
  }
  const bool recovering = recovering_ || starting_;
  if ((available == 1 && rejected == 1) || (recovering && 2 * rejected <= available))
    arm_faulty(reports, count);
  const bool readmit = readmission_due(z, reports, count);
  const bool reset = readmit || lost;
  if (reset) {
    // Lost (most points contradict the covariance for several updates), or a point held out at
    // an earlier reset is plausible against the initial covariance (re-admission: see ekf.hpp).
    // Start the covariance afresh (x kept) and test the same measurements again; when lost, the
    // points already faulty are held out of that test and tested against the others' posterior
    // instead, so that a transmitter that went wrong does not get in through the wide
    // covariance.
    lost_updates_ = 0;
    if (lost) {
      recovering_ = true;
      clean_updates_ = 0;
    }
    ++counters_.covariance_resets;
    counters_.gate_rejections -= rejected;
    for (std::size_t i = 0; i < count; ++i) {
      if (reports[i].rejected) streaks_.uncount(i);
      held_[i] = reports[i].faulty && !readmit ? streaks_.count(i) : -1;
    }
    P_ = P_initial_;
    // Nothing linearised before is trusted after a reset: the next cycle evaluates afresh.
    h_valid_ = false;
    integrator_.forget_jacobian();
    gate(z, reports, count, available);
  }
  P_prior_ = P_;
  for (std::size_t i = 0; i < count; ++i) {
    if (!reports[i].fused || (reset && held_[i] >= 0)) continue;
    if (!reset && recovering)
      streaks_.disarm_keeping_backoff(i);  // fused by the gate; armed again later, after longer
    else if (!reset)
      streaks_.disarm(i);  // fused by the gate
    else if (streaks_.armed(i))
      streaks_.keep_armed(i);  // let in by a reset
    fuse(z[i].output, reports[i].innovation,
         robust_variance(std::max(z[i].variance, options_.min_measurement_variance), reports[i],
                         options_.robust_threshold));
    ++counters_.fused;
  }
  if (reset) retest_held(z, reports, count);
  if (projection_) {
    constraints_->set_inputs(u);
    apply_constraints();
  }
  keep_evaluable(u);
  return finish_step();
}

void Ekf::keep_evaluable(std::span<const double> u) {
  const auto evaluable = [&](Eigen::VectorXd& x) {
    return model_.rhs(span_of(x), u, span_of(xdot_)) == plant::kModelOk &&
           model_.outputs(span_of(x), u, span_of(y_try_)) == plant::kModelOk;
  };
  if (evaluable(x_)) return;
  ++step_backs_;
  double alpha = 1.0;
  for (int i = 0; i < kMaxStepBacks; ++i) {
    alpha *= 0.5;
    x_try_ = x_prior_ + alpha * (x_ - x_prior_);
    if (!evaluable(x_try_)) continue;
    x_ = x_try_;
    P_ *= alpha;
    P_ += (1.0 - alpha) * P_prior_;
    return;
  }
  x_ = x_prior_;  // the prior: its outputs were evaluated at the start of this update
  P_ = P_prior_;
}

std::size_t Ekf::gate(std::span<const Measurement> z, std::span<MeasurementReport> reports,
                      std::size_t count, std::size_t& available) {
  std::size_t rejected = 0;
  available = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const Measurement& mz = z[i];
    MeasurementReport& rep = reports[i];
    rep = MeasurementReport{};
    const auto o = static_cast<Eigen::Index>(mz.output);
    rep.available =
        mz.available && mz.output < m_ && std::isfinite(mz.value) && std::isfinite(mz.variance);
    if (mz.output < m_) rep.predicted = y_(o);  // also for one not offered (a stuck sensor)
    if (!rep.available) continue;
    ++available;
    const double r = std::max(mz.variance, options_.min_measurement_variance);
    ph_.noalias() = P_ * H_.row(o).transpose();
    rep.innovation = mz.value - y_(o);
    rep.innovation_variance = H_.row(o).dot(ph_) + r;
    rep.test_ratio = rep.innovation * rep.innovation / rep.innovation_variance;
    if (!(rep.test_ratio <= options_.nis_gate)) {
      rep.rejected = true;
      ++rejected;
      ++counters_.gate_rejections;
      streaks_.reject(i, mz.value);
    } else {
      rep.fused = true;  // fused by update()
      streaks_.accept(i);
    }
    rep.faulty = streaks_.faulty(i, options_.max_consecutive_rejections);
  }
  return rejected;
}

void Ekf::arm_faulty(std::span<const MeasurementReport> reports, std::size_t count) {
  // A reading that has not changed once in the streak is rather a frozen transmitter than a lost
  // filter: the stuck check's to judge (StuckMonitor), from the model's drift meanwhile, which a
  // reset fusing the frozen value would stop; arm_now() leaves it alone. Due now; readmission_due()
  // doubles the interval, so the next test is 2 x max_consecutive_rejections later, as for a
  // point held out at a reset.
  for (std::size_t i = 0; i < count; ++i)
    if (reports[i].rejected && reports[i].faulty)
      streaks_.arm_now(i, options_.max_consecutive_rejections);
}

bool Ekf::readmission_due(std::span<const Measurement> z,
                          std::span<const MeasurementReport> reports, std::size_t count) {
  bool due = false;
  for (std::size_t i = 0; i < count; ++i) {
    if (!reports[i].rejected || !streaks_.take_due(i)) continue;  // take_due() backs off
    const auto o = static_cast<Eigen::Index>(z[i].output);
    ph_.noalias() = P_initial_ * H_.row(o).transpose();
    const double s0 =
        H_.row(o).dot(ph_) + std::max(z[i].variance, options_.min_measurement_variance);
    if (reports[i].innovation * reports[i].innovation / s0 <= options_.nis_gate) due = true;
  }
  return due;
}

void Ekf::retest_held(std::span<const Measurement> z, std::span<MeasurementReport> reports,
                      std::size_t count) {
  for (std::size_t i = 0; i < count; ++i) {
    MeasurementReport& rep = reports[i];
    if (held_[i] < 0 || !rep.available) continue;
    const auto o = static_cast<Eigen::Index>(z[i].output);
    const double r = std::max(z[i].variance, options_.min_measurement_variance);
    const double nu = rep.innovation - H_.row(o).dot(x_ - x_prior_);
    ph_.noalias() = P_ * H_.row(o).transpose();
    const double s = H_.row(o).dot(ph_) + r;
    rep.test_ratio = nu * nu / s;  // what decides, replacing gate()'s against P_initial alone
    const bool pass = rep.test_ratio <= options_.nis_gate;
    if (pass != rep.fused) {  // gate() counted the other outcome
      if (pass)
        --counters_.gate_rejections;
      else
        ++counters_.gate_rejections;
    }
    rep.fused = pass;
    rep.rejected = !pass;
    streaks_.set_count(i, pass ? 0 : held_[i] + 1);
    if (!pass)  // armed: tested again later (readmission_due)
      streaks_.arm_later(i, 2 * options_.max_consecutive_rejections);
    rep.faulty = streaks_.faulty(i, options_.max_consecutive_rejections);
    if (pass) {
      streaks_.disarm_keeping_backoff(i);  // fused (this is a reset)
      fuse(z[i].output, rep.innovation, r);
      ++counters_.fused;
    }
  }
}

void Ekf::fuse(std::size_t output, double innovation_at_prior, double r) {
  const auto o = static_cast<Eigen::Index>(output);
  const auto n = static_cast<Eigen::Index>(n_);
  const double nu = innovation_at_prior - H_.row(o).dot(x_ - x_prior_);
  ph_.noalias() = P_ * H_.row(o).transpose();
  const double s = H_.row(o).dot(ph_) + r;
  k_ = ph_ / s;
  // Consider states keep their values: no gain; a partial update scales it (the Joseph form
  // below stays exact for any gain).
  for (Eigen::Index i = 0; i < n; ++i) {
    const auto j = static_cast<std::size_t>(i);
    if (consider_[j] != 0)
      k_(i) = 0.0;
    else if (gain_weight_[j] != 1.0)
      k_(i) *= gain_weight_[j];
  }
  x_ += nu * k_;
  // Joseph form P' = (I - k h) P (I - k h)ᵀ + r k kᵀ, as rank-1 updates:
  // B = P - k (P hᵀ)ᵀ, then P' = B - (B hᵀ) kᵀ + r k kᵀ.
  b_ = P_;
  for (Eigen::Index c = 0; c < n; ++c)
    for (Eigen::Index row = 0; row < n; ++row)
      b_(row, c) -= k_(row) * ph_(c);
  bh_.noalias() = b_ * H_.row(o).transpose();
  for (Eigen::Index c = 0; c < n; ++c)
    for (Eigen::Index row = 0; row < n; ++row)
      P_(row, c) = b_(row, c) - bh_(row) * k_(c) + r * k_(row) * k_(c);
}

bool Ekf::output_jacobian_holds(std::span<const double> u) const {
  const double d = options_.integrator.jacobian_reuse_sigma;
  return h_valid_ && d > 0.0 && plant::within_scaled(u, h_u_, h_u_scale_, d) &&
         plant::within_scaled(span_of(x_), span_of(h_x_), span_of(h_scale_), d);
}

int Ekf::outputs_with_jacobian(std::span<const double> u, std::span<double> y) {
  ++h_calls_;
  if (output_jacobian_holds(u)) {
    ++h_reuses_;
    return model_.outputs(span_of(x_), u, y);
  }
  h_valid_ = false;
  const int status = model_.output_jacobian(span_of(x_), u, y, span_of(H_));
  if (status != plant::kModelOk || u.size() != h_u_.size()) return status;
  h_x_ = x_;
  std::copy(u.begin(), u.end(), h_u_.begin());
  h_valid_ = true;
  return status;
}

int Ekf::filter_output_estimates(std::span<const double> u, std::span<double> y,
                                 std::span<double> sigma) {
  const int status = outputs_with_jacobian(u, y);
  if (status != plant::kModelOk) return status;
  for (std::size_t r = 0; r < m_ && r < sigma.size(); ++r) {
    const auto o = static_cast<Eigen::Index>(r);
    ph_.noalias() = P_ * H_.row(o).transpose();
    sigma[r] = std::sqrt(std::max(0.0, H_.row(o).dot(ph_)));
  }
  return plant::kModelOk;
}

StepStatus Ekf::finish_step() {
  // Symmetrise, then clamp variances by congruence with a diagonal scaling (keeps P SPD).
  tmp_ = P_.transpose();
  P_ += tmp_;
  P_ *= 0.5;
  for (Eigen::Index i = 0; i < static_cast<Eigen::Index>(n_); ++i) {
    if (P_(i, i) > max_var_(i)) {
      const double s = std::sqrt(max_var_(i) / P_(i, i));
      P_.row(i) *= s;
      P_.col(i) *= s;
    }
  }
  if (healthy()) {
    x_good_ = x_;
    P_good_ = P_;
    return StepStatus::kOk;
  }
  ++counters_.numerical_resets;
  x_ = x_good_;
  P_ = P_good_;
  return StepStatus::kNumericalReset;
}

bool Ekf::healthy() {
  if (!x_.allFinite() || !P_.allFinite()) return false;
  llt_.compute(P_);
  if (llt_.info() == Eigen::Success) return true;
  // Positive definite but for rounding: through a stiff state F P Fᵀ mixes variances 1e16 apart
  // (fast modes decay to nothing, others grow), and the doubles leave eigenvalues of -1e-14 of
  // the largest where the process noise of a slow parameter adds 1e-12 (measured on the heat
  // pump at tests/unit/plant_models/stiff_state.hpp). Each variance widened by a relative
  // 1e-12, then 1e-10 ... 1e-6, until the factorisation holds: far below what any estimate
  // publishes, where a reset would throw the period's prediction away. Beyond that P is not
  // a rounding away from a covariance, and the step is reset.
  for (double jitter = 1e-12; jitter <= 1e-6; jitter *= 100.0) {
    P_.diagonal() *= 1.0 + jitter;
    llt_.compute(P_);
    if (llt_.info() == Eigen::Success) {
      ++jitters_;
      return true;
    }
  }
  return false;
}

}  // namespace hvac_twin::est
