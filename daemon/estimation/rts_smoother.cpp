#include "daemon/estimation/rts_smoother.hpp"

namespace hvac_twin::est {

RtsSmoother::RtsSmoother(Eigen::Index n, double min_eigenvalue)
    : min_eigenvalue_(min_eigenvalue),
      eig_(n),
      Ct_(n, n),
      tmp_(n, n),
      dP_(n, n),
      d_(n),
      lambda_(n) {}

bool RtsSmoother::step(const Eigen::VectorXd& x, const Eigen::MatrixXd& P,
                       const Eigen::VectorXd& x_prior1, const Eigen::MatrixXd& P_prior1,
                       const Eigen::MatrixXd& F1, const Eigen::VectorXd& xs1,
                       const Eigen::MatrixXd& Ps1, Eigen::VectorXd& xs, Eigen::MatrixXd& Ps) {
  // Cᵀ = (P⁻)⁺ F P, the inverse taken on the correlation scale of P⁻ with the directions below
  // min_eigenvalue_ dropped (see the header).
  d_ = P_prior1.diagonal();
  if (!(d_.array() > 0.0).all() || !P_prior1.allFinite()) return false;
  d_ = d_.cwiseSqrt().cwiseInverse();
  tmp_ = d_.asDiagonal() * P_prior1 * d_.asDiagonal();
  eig_.compute(tmp_);
  if (eig_.info() != Eigen::Success || eig_.eigenvalues()(0) < -1e-9) return false;
  lambda_ = eig_.eigenvalues();
  for (Eigen::Index i = 0; i < lambda_.size(); ++i)
    lambda_(i) = lambda_(i) > min_eigenvalue_ ? 1.0 / lambda_(i) : 0.0;
  // (P⁻)⁺ = D⁻¹ V Λ⁺ Vᵀ D⁻¹ with D⁻¹ = d_
  tmp_.noalias() = eig_.eigenvectors() * lambda_.asDiagonal() * eig_.eigenvectors().transpose();
  dP_.noalias() = F1 * P;
  dP_ = d_.asDiagonal() * dP_;
  Ct_.noalias() = tmp_ * dP_;
  Ct_ = d_.asDiagonal() * Ct_;
  xs.noalias() = x + Ct_.transpose() * (xs1 - x_prior1);
  dP_ = Ps1 - P_prior1;
  tmp_.noalias() = dP_ * Ct_;
  Ps.noalias() = Ct_.transpose() * tmp_;
  Ps += P;
  Ps = 0.5 * (Ps + Ps.transpose()).eval();
  return xs.allFinite() && Ps.allFinite();
}

}  // namespace hvac_twin::est
