#include "daemon/estimation/enkf.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace hvac_twin::est {

// A thread's scratch space: nothing in it outlives one member.
struct ConstrainedEnkf::Worker {
  std::unique_ptr<ConstrainedProjection> projection;
  Eigen::VectorXd xe;
};

// A fixed chain of members (see enkf.hpp): everything that carries over from one member to the
// next, or from one period to the next, is here, so it does not depend on the threads.
struct ConstrainedEnkf::Lane {
  std::size_t begin = 0, end = 0;  // its members
  std::unique_ptr<plant::ContinuousModel> model;
  std::unique_ptr<plant::Integrator> integrator;
  std::vector<double> x, y, w;
  std::vector<int> active;  // rows active for this lane's members in the last constrain()
  std::size_t active_count = 0;
};

namespace {

plant::IntegratorOptions without_sensitivities(plant::IntegratorOptions o) {
  o.sensitivities = false;
  return o;
}

// Adds `row` to the first `count` entries of `rows` unless it is there (or there is no room).
void note_active(std::vector<int>& rows, std::size_t& count, int row) {
  const auto end = rows.begin() + static_cast<long>(count);
  if (std::find(rows.begin(), end, row) == end && count < rows.size()) rows[count++] = row;
}

}  // namespace

template <class Fn>
void ConstrainedEnkf::each_member(Fn& fn) {
  auto task = [&](std::size_t w, std::size_t lb, std::size_t le) {
    for (std::size_t l = lb; l < le; ++l) {
      Lane& lane = *lanes_[l];
      for (std::size_t i = lane.begin; i < lane.end; ++i)
        fn(*workers_[w], lane, i);
    }
  };
  pool_.run(lanes_.size(), task);
}

ConstrainedEnkf::ConstrainedEnkf(const plant::ContinuousModel& model,
                                 std::span<const double> process_noise,
                                 std::size_t max_measurements, const EnkfOptions& options)
    : options_(options),
      n_(model.num_states()),
      m_(model.num_outputs()),
      N_(options.members),
      pool_(options.threads),
      constraints_(model.layout()) {
  if (process_noise.size() != n_)
    throw std::invalid_argument("EnKF: process noise must have one entry per state");
  if (N_ < 4) throw std::invalid_argument("EnKF: at least 4 members");
  const auto n = static_cast<Eigen::Index>(n_), N = static_cast<Eigen::Index>(N_);
  q_ = Eigen::VectorXd(n);
  for (Eigen::Index i = 0; i < n; ++i)
    q_(i) = process_noise[static_cast<std::size_t>(i)] * process_noise[static_cast<std::size_t>(i)];
  for (std::size_t w = 0; w < pool_.size(); ++w) {
    auto worker = std::make_unique<Worker>();
    worker->projection =
        std::make_unique<ConstrainedProjection>(n_, constraints_.rows(), options.projection);
    worker->xe = Eigen::VectorXd::Zero(n);
    workers_.push_back(std::move(worker));
  }
  const std::size_t lanes = std::clamp<std::size_t>(options.lanes, 1, N_);
  for (std::size_t l = 0; l < lanes; ++l) {
    auto lane = std::make_unique<Lane>();
    lane->begin = l * N_ / lanes;
    lane->end = (l + 1) * N_ / lanes;
    lane->model = model.clone();
    lane->integrator = std::make_unique<plant::Integrator>(
        *lane->model, without_sensitivities(options.integrator));
    lane->x.assign(n_, 0.0);
    lane->w.assign(n_, 0.0);
    lane->y.assign(m_, 0.0);
    lane->active.assign(options.projection.max_active + constraints_.rows(), -1);
    lanes_.push_back(std::move(lane));
  }
  for (std::size_t i = 0; i < N_; ++i)
    rng_.emplace_back(options.seed * 1000003ULL + i);
  gauss_.assign(N_, std::normal_distribution<double>(0.0, 1.0));
  X_ = anomalies_ = Eigen::MatrixXd::Zero(n, N);
  mean_ = Eigen::VectorXd::Zero(n);
  P_ = metric_ = Eigen::MatrixXd::Zero(n, n);
  Y_ = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(m_), N);
  ok_.assign(N_, 1);
  const auto f = static_cast<Eigen::Index>(std::max<std::size_t>(max_measurements, 1));
  Ya_ = D_ = Eigen::MatrixXd::Zero(f, N);
  Pxy_ = K_ = Eigen::MatrixXd::Zero(n, f);
  Kt_ = Eigen::MatrixXd::Zero(f, n);
  Pyy_ = Eigen::MatrixXd::Zero(f, f);
  // Sized by a factorisation, not by move-assigning LLT(f): that constructor leaves its
  // ComputationInfo unset, and copying the indeterminate enum is undefined behaviour (UBSan).
  llt_.compute(Eigen::MatrixXd::Identity(f, f));
  ymean_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(m_));
  fused_.assign(static_cast<std::size_t>(f), 0);
  streaks_.resize(max_measurements);
  std0_ = Eigen::VectorXd::Zero(n);
  X_kept_ = Eigen::MatrixXd::Zero(n, N);
  Y_kept_ = Y_;
  ok_kept_ = ok_;
  active_.assign(constraints_.rows(), -1);
  init_consider(model.layout());
  // Sized by a factorisation, for the same reason as llt_.
  restore_P_ = Eigen::MatrixXd::Identity(n, n);
  ldlt_.compute(restore_P_);
  draw_ = Eigen::VectorXd::Zero(n);
}

ConstrainedEnkf::~ConstrainedEnkf() = default;

void ConstrainedEnkf::statistics() {
  mean_ = X_.rowwise().mean();
  anomalies_ = X_.colwise() - mean_;
  P_.noalias() = anomalies_ * anomalies_.transpose();
  P_ /= static_cast<double>(N_ - 1);
}

void ConstrainedEnkf::reset(std::span<const double> x0, std::span<const double> std0) {
  for (std::size_t i = 0; i < N_; ++i)
    for (std::size_t j = 0; j < n_; ++j)
      X_(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(i)) = x0[j] + std0[j] * normal(i);
  for (std::size_t j = 0; j < n_; ++j)
    std0_(static_cast<Eigen::Index>(j)) = std0[j];
  streaks_.clear();
  statistics();
  if (options_.constrained) constrain({});
  statistics();
}

bool ConstrainedEnkf::restore(std::span<const double> x, std::span<const double> P_row_major,
                              const EstimatorCounters& counters) {
  if (!restorable(x, P_row_major, n_)) return false;
  const auto n = static_cast<Eigen::Index>(n_);
  for (Eigen::Index r = 0; r < n; ++r)
    for (Eigen::Index c = 0; c < n; ++c)
      restore_P_(r, c) = P_row_major[static_cast<std::size_t>(r * n + c)];
  // Pivoted LDLT, since an ensemble covariance of fewer members than states is singular:
  // P = Tᵀ L D Lᵀ T, so Tᵀ L √D z with z ~ N(0, I) has covariance P. Written out as loops on
  // preallocated storage (Eigen's triangular products may allocate their blocking workspace).
  ldlt_.compute(restore_P_);
  if (ldlt_.info() != Eigen::Success) return false;
  const auto& L = ldlt_.matrixLDLT();  // unit lower triangle below the diagonal, D on it
  const auto& T = ldlt_.transpositionsP().indices();
  for (std::size_t i = 0; i < N_; ++i) {
    for (Eigen::Index j = 0; j < n; ++j)
      draw_(j) = std::sqrt(std::max(L(j, j), 0.0)) * normal(i);
    for (Eigen::Index r = n - 1; r >= 0; --r) {  // draw_ = L draw_, in place from the bottom
      double v = draw_(r);
      for (Eigen::Index c = 0; c < r; ++c)
        v += L(r, c) * draw_(c);
      draw_(r) = v;
    }
    for (Eigen::Index k = n - 1; k >= 0; --k)  // Tᵀ: the transpositions in reverse order
      std::swap(draw_(k), draw_(T(k)));
    X_.col(static_cast<Eigen::Index>(i)) = draw_;
  }
  // Recentred: the draws' own mean removed, so the ensemble mean is x itself.
  mean_ = X_.rowwise().mean();
  for (Eigen::Index j = 0; j < n; ++j)
    X_.row(j).array() += x[static_cast<std::size_t>(j)] - mean_(j);
  streaks_.clear();
  active_count_ = 0;
  counters_ = counters;
  statistics();
  if (options_.constrained) constrain({});
  statistics();
  return true;
}

StepStatus ConstrainedEnkf::predict(std::span<const double> u, double dt) {
  ++counters_.predicts;
  auto task = [&](Worker&, Lane& L, std::size_t i) {
    const auto I = static_cast<Eigen::Index>(i);
    for (std::size_t j = 0; j < n_; ++j)
      L.x[j] = X_(static_cast<Eigen::Index>(j), I);
    // The process noise as a rate held over the period (see the header): w ~ N(0, Q_c / dt),
    // integrated with the member, so a slow state moves by N(0, Q_c dt) and a stiff one keeps
    // only what its own dynamics leave of it.
    for (std::size_t j = 0; j < n_; ++j)
      L.w[j] = dt > 0.0 ? std::sqrt(q_(static_cast<Eigen::Index>(j)) / dt) * normal(i) : 0.0;
    L.integrator->set_forcing(L.w);
    ok_[i] = L.integrator->step(L.x, u, dt, {}).ok() ? 1 : 0;
    L.integrator->set_forcing({});
    if (!ok_[i]) return;
    for (std::size_t j = 0; j < n_; ++j)
      X_(static_cast<Eigen::Index>(j), I) = L.x[j];
  };
  each_member(task);
  // A member that failed is replaced by a copy of the next one that did not.
  std::size_t failed = 0;
  for (std::size_t i = 0; i < N_; ++i) {
    if (ok_[i]) continue;
    ++failed;
    for (std::size_t k = 1; k < N_; ++k) {
      const std::size_t src = (i + k) % N_;
      if (ok_[src]) {
        X_.col(static_cast<Eigen::Index>(i)) = X_.col(static_cast<Eigen::Index>(src));
        break;
      }
    }
  }
  counters_.predict_failures += failed;
  if (failed == N_) return StepStatus::kModelError;
  statistics();
  // Inflation makes up for the spread the updates take out, so a consider state, which no update
  // touches, keeps its own: inflated too, its spread grew by 2 % a cycle without bound (the heat
  // pump's parameters, held through the settling phase, 5x their prior in 80 cycles; then the
  // members' models failed).
  X_ = (anomalies_ * options_.inflation).colwise() + mean_;
  for (std::size_t j = 0; j < n_; ++j)
    if (consider_[j] != 0) {
      const auto r = static_cast<Eigen::Index>(j);
      X_.row(r) = anomalies_.row(r).array() + mean_(r);
    }
  statistics();
  return X_.allFinite() ? StepStatus::kOk : StepStatus::kModelError;
}

bool ConstrainedEnkf::evaluate_outputs(std::span<const double> u) {
  auto task = [&](Worker&, Lane& L, std::size_t i) {
    const auto I = static_cast<Eigen::Index>(i);
    for (std::size_t j = 0; j < n_; ++j)
      L.x[j] = X_(static_cast<Eigen::Index>(j), I);
    ok_[i] = L.model->outputs(L.x, u, L.y) == plant::kModelOk ? 1 : 0;
    for (std::size_t o = 0; o < m_; ++o)
      Y_(static_cast<Eigen::Index>(o), I) = L.y[o];
  };
  each_member(task);
  return std::all_of(ok_.begin(), ok_.end(), [](char c) { return c != 0; });
}

StepStatus ConstrainedEnkf::update(std::span<const Measurement> z, std::span<const double> u,
                                   std::span<MeasurementReport> reports) {
  ++counters_.updates;
  active_count_ = 0;
  const std::size_t count = std::min({z.size(), reports.size(), streaks_.size(), fused_.size()});
  for (std::size_t i = 0; i < count; ++i)
    reports[i] = MeasurementReport{};
  if (!evaluate_outputs(u)) return StepStatus::kModelError;
  ymean_ = Y_.rowwise().mean();
  const double inv = 1.0 / static_cast<double>(N_ - 1);

  // Gate every available measurement against the ensemble.
  std::size_t f = 0, available = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const Measurement& mz = z[i];
    MeasurementReport& rep = reports[i];
    rep.available =
        mz.available && mz.output < m_ && std::isfinite(mz.value) && std::isfinite(mz.variance);
    const auto o = static_cast<Eigen::Index>(mz.output);
    if (mz.output < m_) rep.predicted = ymean_(o);  // also for one not offered (a stuck sensor)
    if (!rep.available) continue;
    ++available;
    gate(mz, rep);
    if (rep.rejected) {
      ++counters_.gate_rejections;
      streaks_.reject(i, mz.value);
    } else {
      streaks_.accept(i);
      streaks_.disarm(i);  // fused by the gate
      fused_[f++] = i;
    }
    rep.faulty = streaks_.faulty(i, options_.max_consecutive_rejections);
  }
  for (std::size_t i = 0; i < count && available == 1 && f == 0; ++i)
    if (reports[i].rejected && readmit_lone_point(i, z[i], u, reports[i])) fused_[f++] = i;

  if (f > 0) {
    const auto fused_variance = [&](std::size_t k) {  // r, or wider beyond the robust threshold
      return robust_variance(std::max(z[fused_[k]].variance, options_.min_measurement_variance),
                             reports[fused_[k]], options_.robust_threshold);
    };
    // Padded to the workspace size: unused slots are identity rows with zero innovations, so
    // the factorisation never changes size (and never allocates).
    const auto F = Ya_.rows();
    Ya_.setZero();
    D_.setZero();
    Pyy_.setZero();
    for (std::size_t k = 0; k < f; ++k) {
      const Measurement& mz = z[fused_[k]];
      const auto K = static_cast<Eigen::Index>(k), o = static_cast<Eigen::Index>(mz.output);
      const double sd = std::sqrt(fused_variance(k));
      Ya_.row(K) = Y_.row(o).array() - ymean_(o);
      for (std::size_t i = 0; i < N_; ++i) {
        const auto I = static_cast<Eigen::Index>(i);
        D_(K, I) = mz.value + sd * normal(i) - Y_(o, I);
      }
    }
    Pyy_.noalias() = Ya_ * Ya_.transpose();
    Pyy_ *= inv;
    for (std::size_t k = 0; k < f; ++k)
      Pyy_(static_cast<Eigen::Index>(k), static_cast<Eigen::Index>(k)) += fused_variance(k);
    for (auto k = static_cast<Eigen::Index>(f); k < F; ++k)
      Pyy_(k, k) = 1.0;
    Pxy_.noalias() = anomalies_ * Ya_.transpose();
    Pxy_ *= inv;
    llt_.compute(Pyy_);
    if (llt_.info() != Eigen::Success) return StepStatus::kNumericalReset;
    Kt_ = Pxy_.transpose();  // K = Pxy Pyy^-1, i.e. K' = Pyy^-1 Pxy'
    llt_.solveInPlace(Kt_);
    K_ = Kt_.transpose();
    for (std::size_t j = 0; j < n_; ++j) {  // consider states: no gain; partial updates scaled
      if (consider_[j] != 0)
        K_.row(static_cast<Eigen::Index>(j)).setZero();
      else if (gain_weight_[j] != 1.0)
        K_.row(static_cast<Eigen::Index>(j)) *= gain_weight_[j];
    }
    X_.noalias() += K_ * D_;
    counters_.fused += f;
  }
  statistics();
  if (options_.constrained) constrain(u);
  statistics();
  if (!X_.allFinite()) return StepStatus::kNumericalReset;
  return StepStatus::kOk;
}

void ConstrainedEnkf::gate(const Measurement& mz, MeasurementReport& rep) const {
  const auto o = static_cast<Eigen::Index>(mz.output);
  const double r = std::max(mz.variance, options_.min_measurement_variance);
  const double var = (Y_.row(o).array() - ymean_(o)).square().sum() / static_cast<double>(N_ - 1);
  rep.innovation = mz.value - ymean_(o);
  rep.innovation_variance = var + r;
  rep.test_ratio = rep.innovation * rep.innovation / rep.innovation_variance;
  rep.rejected = !(rep.test_ratio <= options_.nis_gate);
  rep.fused = !rep.rejected;
}

bool ConstrainedEnkf::readmit_lone_point(std::size_t i, const Measurement& mz,
                                         std::span<const double> u, MeasurementReport& rep) {
  if (!rep.faulty || !streaks_.varied(i)) return false;  // a frozen reading: see ekf.cpp
  streaks_.arm_now(i, options_.max_consecutive_rejections);
  if (!streaks_.take_due(i)) return false;  // take_due() backs off
  // The members spread again about their mean (recentred: the mean does not move).
  X_kept_ = X_;
  Y_kept_ = Y_;
  ok_kept_ = ok_;
  for (std::size_t k = 0; k < N_; ++k)
    for (std::size_t j = 0; j < n_; ++j) {
      const auto J = static_cast<Eigen::Index>(j);
      X_(J, static_cast<Eigen::Index>(k)) = std0_(J) * normal(k);
    }
  draw_ = X_.rowwise().mean();
  draw_ = mean_ - draw_;
  X_.colwise() += draw_;
  statistics();
  if (options_.constrained) constrain({});
  statistics();
  MeasurementReport retest = rep;
  const bool evaluated = evaluate_outputs(u);
  if (evaluated) {
    ymean_ = Y_.rowwise().mean();
    gate(mz, retest);
  }
  if (!evaluated || retest.rejected) {  // put back as they were, with their outputs
    X_ = X_kept_;
    Y_ = Y_kept_;
    ok_ = ok_kept_;
    statistics();
    ymean_ = Y_.rowwise().mean();
    return false;
  }
  ++counters_.covariance_resets;
  --counters_.gate_rejections;
  streaks_.accept(i);
  streaks_.keep_armed(i);  // let in by a reset
  retest.faulty = false;
  rep = retest;
  return true;
}

void ConstrainedEnkf::constrain(std::span<const double> u) {
  active_count_ = 0;
  constraints_.set_inputs(u);
  // State constraints: each member projected in the metric diag(P).
  metric_.setZero();
  for (Eigen::Index i = 0; i < static_cast<Eigen::Index>(n_); ++i)
    metric_(i, i) = std::max(P_(i, i), 1e-12 * (1.0 + mean_(i) * mean_(i)));
  for (auto& L : lanes_)
    L->active_count = 0;
  auto project = [&](Worker& W, Lane& L, std::size_t i) {
    W.xe = X_.col(static_cast<Eigen::Index>(i));
    W.projection->solve(W.xe, metric_, constraints_.A(), constraints_.b(), constraints_.scale(),
                        constraints_.static_rows());
    for (std::size_t j = 0; j < n_; ++j)  // a consider state keeps its member values
      if (consider_[j] == 0)
        X_(static_cast<Eigen::Index>(j), static_cast<Eigen::Index>(i)) =
            W.xe(static_cast<Eigen::Index>(j));
    for (const int row : W.projection->active())
      note_active(L.active, L.active_count, row);
  };
  each_member(project);

  // Output constraints: a violating member is drawn towards the ensemble mean.
  if (constraints_.has_output_rows() && !u.empty()) {
    statistics();
    auto shrink = [&](Worker&, Lane& L, std::size_t i) {
      const auto I = static_cast<Eigen::Index>(i);
      double alpha = 1.0;
      int violated = -1;
      for (int k = 0; k < 10; ++k, alpha *= 0.5) {
        for (std::size_t j = 0; j < n_; ++j) {
          const auto J = static_cast<Eigen::Index>(j);
          L.x[j] = mean_(J) + alpha * (X_(J, I) - mean_(J));
        }
        if (L.model->outputs(L.x, u, L.y) != plant::kModelOk) continue;
        int row = -1;
        if (constraints_.output_violation(L.y, &row) <= 0.0) break;
        if (violated < 0) violated = row;
      }
      for (std::size_t j = 0; j < n_; ++j)
        if (consider_[j] == 0) X_(static_cast<Eigen::Index>(j), I) = L.x[j];
      if (violated >= 0) note_active(L.active, L.active_count, violated);
    };
    each_member(shrink);
  }
  for (const auto& L : lanes_)  // in lane order: the same list on any number of threads
    for (std::size_t k = 0; k < L->active_count; ++k)
      note_active(active_, active_count_, L->active[k]);

  if (active_count_ > 0) ++counters_.constrained_updates;
}

int ConstrainedEnkf::filter_output_estimates(std::span<const double> u, std::span<double> y,
                                             std::span<double> sigma) {
  if (!evaluate_outputs(u)) return plant::kModelRecoverable;
  const double inv = 1.0 / static_cast<double>(N_ - 1);
  for (std::size_t o = 0; o < m_ && o < y.size(); ++o) {
    const auto O = static_cast<Eigen::Index>(o);
    const double mean = Y_.row(O).mean();
    y[o] = mean;
    if (o < sigma.size()) sigma[o] = std::sqrt((Y_.row(O).array() - mean).square().sum() * inv);
  }
  return plant::kModelOk;
}

}  // namespace hvac_twin::est
