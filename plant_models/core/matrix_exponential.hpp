// exp(A) for a dense n x n matrix, by scaling and squaring with Padé approximants: the
// algorithm of A. H. Al-Mohy and N. J. Higham, "A new scaling and squaring algorithm for the
// matrix exponential", SIAM J. Matrix Anal. Appl. 31(3), 2009 (algorithm 5.1), on the coefficients
// and thresholds theta_m of N. J. Higham, SIAM J. Matrix Anal. Appl. 26(4), 2005. The degree m
// (3, 5, 7, 9 or 13) and the squarings s are chosen from d_k = ||A^k||^(1/k) (1-norm) rather than
// from ||A||: for a non-normal matrix, as a stiff model's Jacobian is, d_k can be far below
// ||A||, and the 2005 algorithm's s from ||A|| over-scales (costs squarings and loses accuracy).
// The powers A^2, A^4, A^6 the approximant needs anyway give d_2, d_4, d_6 exactly; d_8 and d_10
// are bounded above by their products (||A^8|| <= ||A^2|| ||A^6||, ...), so the backward error
// bound holds. The ell() correction adds squarings where the approximant's own evaluation would
// lose accuracy: || |A|^(2m+1) ||_1, computed exactly as the largest column sum of a nonnegative
// matrix's power, by 2m + 1 matrix-vector products. Two to six matrix products, one LU solve and
// s squarings. Measured on the demo heat pump's replay (3 h at a 1 s period, the README's
// "Replay" timing): 84.7 -> 81.3 s against the 2005 algorithm at its largest degree, with the
// same estimates.
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

  // The squarings (s above) and the approximant's degree (m) the last compute() took, for
  // statistics and tests.
  [[nodiscard]] int last_squarings() const { return squarings_; }
  [[nodiscard]] int last_degree() const { return degree_; }

 private:
  // Scales a_ to D^-1 a_ D, D = diag(d_) in powers of two, so that each state's row and column
  // have comparable norms (Parlett and Reinsch's balancing, as LAPACK's xGEBAL without its
  // permutations): a model's Jacobian mixes units (kJ/kg, K, kg), and its 1-norm, which sets
  // the squarings, falls by orders of magnitude while the exponential is unchanged.
  void balance();
  // Al-Mohy and Higham's ell(scale * a_, m): the squarings to add so that the degree-m
  // approximant's evaluation error stays below the unit round-off; a_norm is ||scale * a_||_1.
  int rounding_squarings(int m, double scale, double a_norm);
  // u_ = U, v_ = V of the degree-m approximant (m = 3, 5, 7 or 9) from a_ and its even powers;
  // for m = 9, u_ holds A^8 on entry.
  void low_degree(int m);

  Eigen::MatrixXd a_, a2_, a4_, a6_, u_, v_, t_;
  Eigen::VectorXd d_, w_, w2_;
  Eigen::PartialPivLU<Eigen::MatrixXd> lu_;
  int squarings_ = 0;
  int degree_ = 0;
};

}  // namespace hvac_twin::plant
