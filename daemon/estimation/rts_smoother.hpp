// The Rauch-Tung-Striebel fixed-interval smoother: after the fact, every estimate of an interval
// from all of its measurements, earlier and later, with its covariance. It runs backwards over
// what the EKF stored forwards: per step k its posterior (x_k, P_k), and the prior of the next
// step (x⁻_{k+1}, P⁻_{k+1}) with the transition F_{k+1} that led there:
//   C_k  = P_k F_{k+1}ᵀ (P⁻_{k+1})⁻¹
//   xs_k = x_k + C_k (xs_{k+1} - x⁻_{k+1})
//   Ps_k = P_k + C_k (Ps_{k+1} - P⁻_{k+1}) C_kᵀ
// starting from the last posterior (xs_N = x_N, Ps_N = P_N). For a linear-Gaussian model it is
// the batch least-squares estimate over the interval (rts_smoother_test checks it); on the EKF it
// uses the filter's linearisation, as the filter did. A constrained update's truncation is in
// P_k, so the smoother inherits it; a smoothed estimate is not projected on the constraints again.
//
// On a stiff model whose fast states have next to no process noise, C is about F⁻¹ on them, and
// the backward pass amplifies every linearisation error by 1/|eigenvalue of F| per step. So the
// smoother may condition only on the directions of the prior that carry variance: on the
// correlation scale of P⁻ (D⁻¹ P⁻ D⁻¹, D its standard deviations) it keeps the eigendirections
// with eigenvalue above min_eigenvalue and leaves the rest to the filter. That is the optimal
// smoother given the prior's projection on those directions, so Ps stays its covariance.
#pragma once

#include <Eigen/Dense>

namespace hvac_twin::est {

class RtsSmoother {
 public:
  // min_eigenvalue: directions of P⁻ whose variance, on its correlation scale, is below this
  // are left to the filter (C = 0 there); 0: the textbook smoother.
  explicit RtsSmoother(Eigen::Index n, double min_eigenvalue = 0.0);

  // One backward step, from the smoothed (xs1, Ps1) at k+1 to (xs, Ps) at k. False (xs, Ps
  // untouched) if P⁻_{k+1} is not positive definite: the interval breaks there. No allocation
  // once built.
  bool step(const Eigen::VectorXd& x, const Eigen::MatrixXd& P, const Eigen::VectorXd& x_prior1,
            const Eigen::MatrixXd& P_prior1, const Eigen::MatrixXd& F1, const Eigen::VectorXd& xs1,
            const Eigen::MatrixXd& Ps1, Eigen::VectorXd& xs, Eigen::MatrixXd& Ps);

 private:
  double min_eigenvalue_;
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig_;
  Eigen::MatrixXd Ct_, tmp_, dP_;
  Eigen::VectorXd d_, lambda_;
};

}  // namespace hvac_twin::est
