// The constrained update as a dense QP: the point closest to x0 in the metric of P^-1 that
// satisfies A x <= b,
//     minimise (x - x0)' P^-1 (x - x0)   subject to   A x <= b.
// With x0 and P the unconstrained (Joseph) update and its covariance, and a linear measurement
// model, this is exactly argmin ||x - x^-||^2_{P^-^-1} + ||y - H x||^2_{R^-1} s.t. A x <= b.
//
// Method: a dual active-set iteration (in the spirit of Goldfarb-Idnani). It starts at the
// unconstrained optimum x0, adds the most violated constraint, solves for the multipliers of the
// active set from the small system (A_a P A_a') lambda = A_a x0 - b_a, drops the most negative
// multiplier while any is negative, and stops when nothing is violated. x = x0 - P A_a' lambda.
// Never needs P^-1. Each iteration costs O(m n) to find the worst violation, O(n^2) to add a
// constraint, O(k^3) for the k x k solve: with the caps below the worst case is bounded and
// known at construction (see max_iterations).
//
// Construction allocates (all workspace); solve() never allocates or throws. One instance per
// thread.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cstddef>
#include <span>

namespace hvac_twin::est {

struct ProjectionOptions {
  std::size_t max_active = 24;  // largest active set
  int max_iterations = 64;      // additions plus drops
  double tolerance = 1e-9;      // a constraint counts as violated above b + tolerance * scale
};

struct ProjectionResult {
  bool converged = false;  // feasible within tolerance and every multiplier >= 0
  int iterations = 0;
  std::size_t active = 0;  // constraints active at the solution (listed by active())
};

class ConstrainedProjection {
 public:
  // n states, at most m constraints.
  ConstrainedProjection(std::size_t n, std::size_t m, ProjectionOptions options = {});

  // x: in x0, out the projected point. A: m x n (rows constraints; only the first `rows` used),
  // b: their bounds, scale: per-row magnitude for the tolerance (e.g. |b| + 1). P symmetric
  // positive definite.
  ProjectionResult solve(Eigen::Ref<Eigen::VectorXd> x, const Eigen::MatrixXd& P,
                         const Eigen::MatrixXd& A, const Eigen::VectorXd& b,
                         const Eigen::VectorXd& scale, std::size_t rows);

  // Row indices of the constraints active at the last solution, and their multipliers.
  [[nodiscard]] std::span<const int> active() const { return {active_.data(), count_}; }
  [[nodiscard]] double multiplier(std::size_t k) const {
    return lambda_(static_cast<Eigen::Index>(k));
  }

 private:
  bool solve_multipliers();

  ProjectionOptions options_;
  std::size_t count_ = 0;
  Eigen::VectorXi active_;  // row indices, first count_ used
  Eigen::MatrixXd pa_;      // n x max_active: P a_j of the active rows
  Eigen::MatrixXd m_;       // max_active^2: A_a P A_a'
  Eigen::VectorXd rhs_, lambda_;
  Eigen::VectorXd x0_;
  Eigen::LLT<Eigen::MatrixXd> llt_;
  Eigen::MatrixXd m_k_;  // the k x k leading block, factorised
  Eigen::VectorXd rhs_k_;
  Eigen::VectorXd dep_, dep_r_;  // the dual step for a dependent row
};

}  // namespace hvac_twin::est
