// exp(A) for a dense n x n matrix, by scaling and squaring with the [13/13] Padé approximant
// (N. J. Higham, "The scaling and squaring method for the matrix exponential revisited", SIAM J.
// Matrix Anal. Appl. 26(4), 2005, algorithm 2.3 at its largest degree): A is scaled by 2^-s so
// that its 1-norm is at most theta_13 = 5.37, where the approximant's backward error is below
// the unit round-off, then r_13(A / 2^s) is squared s times. Six matrix products, one LU
// solve and s squarings; a stiff model's Jacobian times a 5 s period (1-norm ~1e4) takes s ~ 11.
//
// Ownership: owns its workspace, sized at construction; compute() never throws and does not
// allocate for n up to about 120 (above that Eigen's blocked products and LU take packing
// buffers from the heap). Not thread-safe: one per integrator.
#pragma once

#include <Eigen/Core>
#include <Eigen/LU>

namespace hvac_twin::plant {

class MatrixExponential {
 public:
  explicit MatrixExponential(Eigen::Index n);

  // out = exp(A) (A and out n x n; out may not alias A). Returns false, out unspecified, if A
  // is not finite or the Padé denominator is singular.
  bool compute(const Eigen::Ref<const Eigen::MatrixXd>& A, Eigen::Ref<Eigen::MatrixXd> out);

  // Squarings the last compute() took (s above), for statistics and tests.
  [[nodiscard]] int last_squarings() const { return squarings_; }

 private:
  // Scales a_ to D^-1 a_ D, D = diag(d_) in powers of two, so that each state's row and column
  // have comparable norms (Parlett and Reinsch's balancing, as LAPACK's xGEBAL without its
  // permutations): a model's Jacobian mixes units (kJ/kg, K, kg), and its 1-norm, which sets
  // the squarings, falls by orders of magnitude while the exponential is unchanged.
  void balance();

  Eigen::MatrixXd a_, a2_, a4_, a6_, u_, v_, t_;
  Eigen::VectorXd d_;
  Eigen::PartialPivLU<Eigen::MatrixXd> lu_;
  int squarings_ = 0;
};

}  // namespace hvac_twin::plant
