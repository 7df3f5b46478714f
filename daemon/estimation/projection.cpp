// The dual of the projection is   min_{lambda >= 0}  1/2 lambda' G lambda - lambda' h,
// G = A P A', h = A x0 - b, with x = x0 - P A' lambda and gradient -(A x - b): a
// non-negative least-squares problem solved by the Lawson-Hanson active-set method (the
// "passive" set is the set of active constraints). Adding the most violated constraint is the
// steepest dual step; a multiplier that would turn negative is handled by a partial step to the
// first zero, which removes it. This terminates finitely for positive definite G_SS.
#include "daemon/estimation/projection.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hvac_twin::est {
namespace {

// In-place Cholesky of the leading k x k block of M (lower triangle), then solves M z = r.
// False if the block is not positive definite (dependent active constraints).
bool cholesky_solve(Eigen::MatrixXd& L, const Eigen::MatrixXd& M, std::size_t k,
                    const Eigen::VectorXd& r, Eigen::VectorXd& z) {
  const auto n = static_cast<Eigen::Index>(k);
  for (Eigen::Index j = 0; j < n; ++j) {
    double d = M(j, j);
    for (Eigen::Index p = 0; p < j; ++p)
      d -= L(j, p) * L(j, p);
    if (!(d > 1e-14 * std::abs(M(j, j))) || !(d > 0.0)) return false;
    L(j, j) = std::sqrt(d);
    for (Eigen::Index i = j + 1; i < n; ++i) {
      double s = M(i, j);
      for (Eigen::Index p = 0; p < j; ++p)
        s -= L(i, p) * L(j, p);
      L(i, j) = s / L(j, j);
    }
  }
  for (Eigen::Index i = 0; i < n; ++i) {  // L y = r
    double s = r(i);
    for (Eigen::Index p = 0; p < i; ++p)
      s -= L(i, p) * z(p);
    z(i) = s / L(i, i);
  }
  for (Eigen::Index i = n - 1; i >= 0; --i) {  // L' z = y
    double s = z(i);
    for (Eigen::Index p = i + 1; p < n; ++p)
      s -= L(p, i) * z(p);
    z(i) = s / L(i, i);
  }
  return true;
}

}  // namespace

ConstrainedProjection::ConstrainedProjection(std::size_t n, std::size_t m,
                                             ProjectionOptions options)
    : options_(options) {
  const auto k = static_cast<Eigen::Index>(std::min(options.max_active, m));
  options_.max_active = static_cast<std::size_t>(k);
  active_ = Eigen::VectorXi::Zero(k);
  pa_ = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(n), k);
  m_ = m_k_ = Eigen::MatrixXd::Zero(k, k);
  rhs_ = lambda_ = rhs_k_ = dep_ = dep_r_ = Eigen::VectorXd::Zero(k);
  x0_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n));
}

bool ConstrainedProjection::solve_multipliers() {
  // rhs_k_ holds the solution z of G_SS z = h_S for the current active set.
  return cholesky_solve(m_k_, m_, count_, rhs_, rhs_k_);
}

ProjectionResult ConstrainedProjection::solve(Eigen::Ref<Eigen::VectorXd> x,
                                              const Eigen::MatrixXd& P, const Eigen::MatrixXd& A,
                                              const Eigen::VectorXd& b,
                                              const Eigen::VectorXd& scale, std::size_t rows) {
  ProjectionResult result;
  x0_ = x;
  count_ = 0;
  const auto is_active = [this](Eigen::Index r) {
    for (std::size_t i = 0; i < count_; ++i)
      if (active_(static_cast<Eigen::Index>(i)) == r) return true;
    return false;
  };
  const auto remove = [this](std::size_t j) {  // move the last entry into slot j
    const auto J = static_cast<Eigen::Index>(j), last = static_cast<Eigen::Index>(count_ - 1);
    active_(J) = active_(last);
    lambda_(J) = lambda_(last);
    rhs_(J) = rhs_(last);
    pa_.col(J) = pa_.col(last);
    m_.row(J).head(last + 1) = m_.row(last).head(last + 1);
    m_.col(J).head(last + 1) = m_.col(last).head(last + 1);
    m_(J, J) = m_(last, last);
    --count_;
  };

  while (result.iterations < options_.max_iterations) {
    // The most violated constraint not yet active (the steepest dual ascent direction).
    Eigen::Index worst = -1;
    double worst_violation = options_.tolerance;
    for (Eigen::Index r = 0; r < static_cast<Eigen::Index>(rows); ++r) {
      const double v = (A.row(r).dot(x) - b(r)) / scale(r);
      if (v > worst_violation && !is_active(r)) {
        worst = r;
        worst_violation = v;
      }
    }
    if (worst < 0) {
      result.converged = true;
      break;
    }
    if (count_ == options_.max_active) break;
    auto k = static_cast<Eigen::Index>(count_);
    active_(k) = static_cast<int>(worst);
    lambda_(k) = 0.0;
    rhs_(k) = A.row(worst).dot(x0_) - b(worst);
    pa_.col(k).noalias() = P * A.row(worst).transpose();
    for (Eigen::Index i = 0; i <= k; ++i) {
      m_(i, k) = A.row(active_(i)).dot(pa_.col(k));
      m_(k, i) = m_(i, k);
    }
    // A row dependent on the active ones (in the metric of P): the Goldfarb-Idnani dual step.
    // With G_AA r = G_Aj, raising its multiplier by t and lowering the others by t r leaves x
    // unchanged; go as far as the first active multiplier reaching zero and drop that one.
    if (k > 0) {
      for (Eigen::Index i = 0; i < k; ++i)
        dep_(i) = m_(i, k);
      if (cholesky_solve(m_k_, m_, count_, dep_, dep_r_)) {
        const double schur = m_(k, k) - m_.col(k).head(k).dot(dep_r_.head(k));
        if (!(schur > 1e-12 * m_(k, k))) {
          double t = std::numeric_limits<double>::infinity();
          Eigen::Index blocking = -1;
          for (Eigen::Index i = 0; i < k; ++i)
            if (dep_r_(i) > 0.0 && lambda_(i) / dep_r_(i) < t) {
              t = lambda_(i) / dep_r_(i);
              blocking = i;
            }
          if (blocking < 0) break;  // the constraints cannot all hold: infeasible
          for (Eigen::Index i = 0; i < k; ++i)
            lambda_(i) -= t * dep_r_(i);
          lambda_(k) = t;
          ++count_;
          remove(static_cast<std::size_t>(blocking));
          ++result.iterations;
          k = static_cast<Eigen::Index>(count_) - 1;
          --count_;
        }
      }
    }
    ++count_;

    // Inner loop: the unconstrained minimiser z on the active set; step back to keep every
    // multiplier non-negative, dropping those that reach zero.
    bool ok = true;
    while (result.iterations++ < options_.max_iterations) {
      if (!solve_multipliers()) {
        remove(count_ - 1);  // dependent on the active set: it cannot be satisfied separately
        ok = false;
        break;
      }
      double alpha = 1.0;
      for (std::size_t i = 0; i < count_; ++i) {
        const auto I = static_cast<Eigen::Index>(i);
        if (rhs_k_(I) <= 0.0) alpha = std::min(alpha, lambda_(I) / (lambda_(I) - rhs_k_(I)));
      }
      for (std::size_t i = 0; i < count_; ++i) {
        const auto I = static_cast<Eigen::Index>(i);
        lambda_(I) += alpha * (rhs_k_(I) - lambda_(I));
      }
      if (alpha >= 1.0) break;
      for (std::size_t i = count_; i-- > 0;)
        if (lambda_(static_cast<Eigen::Index>(i)) <= 1e-300) remove(i);
    }
    x = x0_;
    for (std::size_t i = 0; i < count_; ++i)
      x -= pa_.col(static_cast<Eigen::Index>(i)) * lambda_(static_cast<Eigen::Index>(i));
    if (!ok) break;
  }
  result.active = count_;
  return result;
}

}  // namespace hvac_twin::est
