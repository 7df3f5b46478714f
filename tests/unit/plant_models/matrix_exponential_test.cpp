#include "plant_models/core/matrix_exponential.hpp"

#include <Eigen/Dense>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <random>
#include <unsupported/Eigen/MatrixFunctions>

using hvac_twin::plant::MatrixExponential;

namespace {

double relative(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).norm() / b.norm();
}

// A random n x n matrix with N(0, 1/n) entries, minus shift times the identity (decaying, as a
// stable model's Jacobian).
Eigen::MatrixXd random_decaying(Eigen::Index n, unsigned seed, double shift) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> N01;
  Eigen::MatrixXd A(n, n);
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < n; ++j)
      A(i, j) = N01(rng) / std::sqrt(static_cast<double>(n));
  A -= shift * Eigen::MatrixXd::Identity(n, n);
  return A;
}

}  // namespace

TEST_CASE("the matrix exponential equals closed forms", "[integrator][expm]") {
  SECTION("a rotation generator gives the rotation") {
    const double w = 3.0;
    Eigen::MatrixXd A(2, 2), R(2, 2), E(2, 2);
    A << 0.0, -w, w, 0.0;
    R << std::cos(w), -std::sin(w), std::sin(w), std::cos(w);
    MatrixExponential expm(2);
    REQUIRE(expm.compute(A, E));
    CHECK(relative(E, R) < 1e-14);
  }
  SECTION("a nilpotent matrix gives its finite series") {
    Eigen::MatrixXd N = Eigen::MatrixXd::Zero(3, 3), E(3, 3);
    N(0, 1) = 2.0;
    N(1, 2) = -3.0;
    N(0, 2) = 0.5;
    const Eigen::MatrixXd series = Eigen::MatrixXd::Identity(3, 3) + N + 0.5 * N * N;
    MatrixExponential expm(3);
    REQUIRE(expm.compute(N, E));
    CHECK(relative(E, series) < 1e-15);
  }
  SECTION("a stiff matrix, eigenvalues from -2e4 to 0.2, by its eigendecomposition") {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> U(-1.0, 1.0);
    const Eigen::Index n = 6;
    Eigen::MatrixXd V = Eigen::MatrixXd::Identity(n, n);
    for (Eigen::Index i = 0; i < n; ++i)
      for (Eigen::Index j = 0; j < n; ++j)
        V(i, j) += 0.3 * U(rng);
    Eigen::VectorXd d(n);
    d << -2e4, -300.0, -1.0, -0.01, 0.2, 0.0;
    const Eigen::MatrixXd Vi = V.inverse();
    const Eigen::MatrixXd A = V * d.asDiagonal() * Vi;
    const Eigen::MatrixXd exact = V * d.array().exp().matrix().asDiagonal() * Vi;
    Eigen::MatrixXd E(n, n);
    MatrixExponential expm(n);
    REQUIRE(expm.compute(A, E));
    INFO("squarings " << expm.last_squarings() << ", error " << relative(E, exact));
    CHECK(expm.last_squarings() >= 12);  // scaled from a 1-norm of ~3e4 down to 5.4
    CHECK(relative(E, exact) < 1e-10);   // seen: 1.4e-12, the reference's own V^-1 included
  }
}

TEST_CASE("the matrix exponential agrees with Eigen's at the heat pump's size and refuses NaN",
          "[integrator][expm]") {
  const Eigen::Index n = 64;
  Eigen::MatrixXd A(n, n), E(n, n);
  MatrixExponential expm(n);
  unsigned seed = 11;
  for (const double scale : {1e-3, 1.0, 30.0}) {
    A = scale * random_decaying(n, seed++, 2.0);
    const Eigen::MatrixXd reference = A.exp();
    REQUIRE(expm.compute(A, E));
    INFO("scale " << scale << ", squarings " << expm.last_squarings());
    CHECK(relative(E, reference) < 1e-11);
  }
  A(3, 5) = std::numeric_limits<double>::quiet_NaN();
  CHECK_FALSE(expm.compute(A, E));
  A(3, 5) = std::numeric_limits<double>::infinity();
  CHECK_FALSE(expm.compute(A, E));
}

TEST_CASE("balancing takes a badly scaled matrix's squarings down to those of its scaled form",
          "[integrator][expm]") {
  // A = D B D^-1 with states in units six orders of magnitude apart, as kJ/kg, K and kg mix in a
  // model's Jacobian: exp(A) = D exp(B) D^-1, and balancing should find D back.
  const Eigen::Index n = 4;
  Eigen::MatrixXd B(n, n);
  B << -1.0, 0.5, 0.2, 0.0,  //
      0.3, -2.0, 0.1, 0.4,   //
      0.0, 0.6, -1.5, 0.2,   //
      0.1, 0.0, 0.3, -0.5;
  Eigen::VectorXd d(n);
  d << 1.0, 1e4, 1e-4, 1e6;
  const Eigen::MatrixXd A = d.asDiagonal() * B * d.cwiseInverse().asDiagonal();
  REQUIRE(A.cwiseAbs().colwise().sum().maxCoeff() > 1e5);  // unbalanced: 2^15 x theta_13
  Eigen::MatrixXd E(n, n);
  MatrixExponential expm(n);
  REQUIRE(expm.compute(A, E));
  const Eigen::MatrixXd exact = d.asDiagonal() * B.exp() * d.cwiseInverse().asDiagonal();
  INFO("squarings " << expm.last_squarings());
  CHECK(expm.last_squarings() == 0);  // B's 1-norm is below theta_13
  for (Eigen::Index i = 0; i < n; ++i)
    for (Eigen::Index j = 0; j < n; ++j)
      CHECK(E(i, j) == Approx(exact(i, j)).epsilon(1e-12).margin(1e-300));
}

TEST_CASE("each Padé degree is taken where its d_k allow it, and is as accurate as degree 13",
          "[integrator][expm]") {
  // A stable 64 x 64 matrix scaled so that its powers' norms fall in each degree's range
  // (Higham's theta_3, theta_5, theta_7, theta_9, then degree 13 without and with squarings).
  const Eigen::Index n = 64;
  Eigen::MatrixXd B = random_decaying(n, 5, 1.0), E(n, n);
  B /= B.cwiseAbs().colwise().sum().maxCoeff();  // 1-norm 1
  MatrixExponential expm(n);
  struct Case {
    double norm;
    int degree;
  };
  for (const Case c :
       {Case{0.005, 3}, Case{0.1, 5}, Case{0.5, 7}, Case{1.2, 9}, Case{3.0, 13}, Case{40.0, 13}}) {
    const Eigen::MatrixXd A = c.norm * B;
    REQUIRE(expm.compute(A, E));
    const Eigen::MatrixXd reference = A.exp();
    INFO("1-norm " << c.norm << ": degree " << expm.last_degree() << ", squarings "
                   << expm.last_squarings() << ", error " << relative(E, reference));
    CHECK(expm.last_degree() == c.degree);
    CHECK(relative(E, reference) < 1e-13);
  }
}

TEST_CASE("a non-normal matrix is scaled by its powers' norms, not by its own norm",
          "[integrator][expm]") {
  // Al-Mohy and Higham's motivating case: [[a, b], [0, c]] with |b| >> |a|, |c|. Its 1-norm
  // (1e6) would ask for 18 squarings; ||A^k||^(1/k) falls towards max(|a|, |c|) as k grows,
  // and the exponential is in closed form. Balancing leaves it alone (its first column has no
  // off-diagonal entry).
  const double a = -1.0, b = 1e6, c = -2.0;
  Eigen::MatrixXd A(2, 2), E(2, 2), exact(2, 2);
  A << a, b, 0.0, c;
  exact << std::exp(a), b * (std::exp(a) - std::exp(c)) / (a - c), 0.0, std::exp(c);
  MatrixExponential expm(2);
  REQUIRE(expm.compute(A, E));
  INFO("squarings " << expm.last_squarings() << ", error " << relative(E, exact));
  CHECK(expm.last_squarings() <= 8);
  CHECK(relative(E, exact) < 1e-13);
}
