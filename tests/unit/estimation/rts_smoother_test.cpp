// The RTS smoother on a linear-Gaussian model, where the smoothed estimates are the batch
// least-squares solution over the whole interval: its means and marginal covariances.
#include "daemon/estimation/rts_smoother.hpp"

#include <catch2/catch.hpp>
#include <random>
#include <vector>

using namespace hvac_twin;
using Eigen::MatrixXd;
using Eigen::VectorXd;

TEST_CASE("RTS smoothing of a linear Kalman filter equals the batch solution", "[rts]") {
  // Constant velocity, position measured: x = [p, v].
  const int n = 2, steps = 30;
  MatrixXd A(n, n), Q(n, n), P0(n, n), H(1, n);
  A << 1.0, 0.5, 0.0, 1.0;
  Q << 0.02, 0.0, 0.0, 0.05;
  P0 << 4.0, 0.0, 0.0, 1.0;
  H << 1.0, 0.0;
  const double R = 0.3;
  VectorXd m0(n);
  m0 << 0.0, 1.0;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<double> z;
  VectorXd truth = m0;
  for (int k = 0; k <= steps; ++k) {
    z.push_back((H * truth)(0) + std::sqrt(R) * noise(rng));
    truth = A * truth + VectorXd::Constant(n, 0.1 * noise(rng));
  }

  // Forward: the Kalman filter, storing what the smoother needs.
  std::vector<VectorXd> x(steps + 1), x_prior(steps + 1);
  std::vector<MatrixXd> P(steps + 1), P_prior(steps + 1);
  for (int k = 0; k <= steps; ++k) {
    x_prior[k] = k == 0 ? m0 : VectorXd(A * x[k - 1]);
    P_prior[k] = k == 0 ? P0 : MatrixXd(A * P[k - 1] * A.transpose() + Q);
    const double S = (H * P_prior[k] * H.transpose())(0) + R;
    const VectorXd K = P_prior[k] * H.transpose() / S;
    x[k] = x_prior[k] + K * (z[k] - (H * x_prior[k])(0));
    P[k] = (MatrixXd::Identity(n, n) - K * H) * P_prior[k];
  }

  // Backward.
  est::RtsSmoother rts(n);
  std::vector<VectorXd> xs(steps + 1);
  std::vector<MatrixXd> Ps(steps + 1);
  xs[steps] = x[steps];
  Ps[steps] = P[steps];
  for (int k = steps - 1; k >= 0; --k) {
    xs[k].resize(n);
    Ps[k].resize(n, n);
    REQUIRE(rts.step(x[k], P[k], x_prior[k + 1], P_prior[k + 1], A, xs[k + 1], Ps[k + 1], xs[k],
                     Ps[k]));
  }

  // Batch: minimise the prior, process and measurement terms over all states at once; the
  // information matrix's inverse holds the marginal covariances.
  const int N = n * (steps + 1);
  MatrixXd L = MatrixXd::Zero(N, N);
  VectorXd b = VectorXd::Zero(N);
  const MatrixXd P0i = P0.inverse(), Qi = Q.inverse();
  L.block(0, 0, n, n) += P0i;
  b.segment(0, n) += P0i * m0;
  for (int k = 0; k <= steps; ++k) {
    L.block(n * k, n * k, n, n) += H.transpose() * H / R;
    b.segment(n * k, n) += H.transpose() * z[k] / R;
    if (k == steps) continue;
    // (x_{k+1} - A x_k)ᵀ Q⁻¹ (x_{k+1} - A x_k)
    L.block(n * k, n * k, n, n) += A.transpose() * Qi * A;
    L.block(n * k, n * (k + 1), n, n) -= A.transpose() * Qi;
    L.block(n * (k + 1), n * k, n, n) -= Qi * A;
    L.block(n * (k + 1), n * (k + 1), n, n) += Qi;
  }
  const MatrixXd cov = L.inverse();
  const VectorXd mean = cov * b;
  for (int k = 0; k <= steps; ++k) {
    INFO("step " << k);
    CHECK((xs[k] - mean.segment(n * k, n)).norm() < 1e-9);
    CHECK((Ps[k] - cov.block(n * k, n * k, n, n)).norm() < 1e-9);
    // Smoothing uses more data: never less certain than the filter.
    CHECK(Ps[k](0, 0) <= P[k](0, 0) + 1e-12);
  }
  // And the filter alone is not the batch solution (the test can tell them apart).
  CHECK((x[0] - mean.segment(0, n)).norm() > 1e-3);
}

TEST_CASE("RTS refuses a prior covariance that is not positive definite", "[rts]") {
  est::RtsSmoother rts(2);
  const MatrixXd I = MatrixXd::Identity(2, 2);
  VectorXd xs = VectorXd::Constant(2, 7.0);
  MatrixXd Ps = I;
  MatrixXd bad(2, 2);
  bad << 1.0, 2.0, 2.0, 1.0;  // indefinite
  CHECK_FALSE(
      rts.step(VectorXd::Zero(2), I, VectorXd::Zero(2), bad, I, VectorXd::Ones(2), I, xs, Ps));
  CHECK(xs(0) == 7.0);  // untouched
}

TEST_CASE("RTS with a minimum eigenvalue leaves nearly deterministic directions to the filter",
          "[rts]") {
  // Two states the prior holds almost perfectly correlated (correlation eigenvalues 1.99999 and
  // 1e-5): the difference of the two is nearly known, their sum is not.
  MatrixXd P(2, 2);
  P << 1.0, 0.99999, 0.99999, 1.0;
  const MatrixXd F = MatrixXd::Identity(2, 2);  // no process noise: P⁻ = P
  const VectorXd x = VectorXd::Zero(2);
  VectorXd along_sum(2), along_difference(2);
  along_sum << 1.0, 1.0;
  along_difference << 1.0, -1.0;
  VectorXd xs(2);
  MatrixXd Ps(2, 2);

  est::RtsSmoother textbook(2), reduced(2, 0.1);
  // The later estimate moved along the sum: both pass it on whole (C = I there).
  REQUIRE(textbook.step(x, P, x, P, F, 0.1 * along_sum, P, xs, Ps));
  CHECK((xs - 0.1 * along_sum).norm() < 1e-6);
  REQUIRE(reduced.step(x, P, x, P, F, 0.1 * along_sum, P, xs, Ps));
  CHECK((xs - 0.1 * along_sum).norm() < 1e-6);
  // Along the difference: the textbook smoother passes it on too; the reduced one does not.
  REQUIRE(textbook.step(x, P, x, P, F, 0.1 * along_difference, P, xs, Ps));
  CHECK((xs - 0.1 * along_difference).norm() < 1e-6);
  REQUIRE(reduced.step(x, P, x, P, F, 0.1 * along_difference, P, xs, Ps));
  CHECK(xs.norm() < 1e-6);
  // Without new information (Ps1 = P⁻) the smoothed covariance is the filter's.
  CHECK((Ps - P).norm() < 1e-9);
}
