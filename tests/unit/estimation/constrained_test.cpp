// The constrained update's pieces: the QP projection against brute-force enumeration of active
// sets, and the PDF truncation against numerical integration.
#include <Eigen/Dense>
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include "daemon/estimation/projection.hpp"
#include "daemon/estimation/truncation.hpp"

using namespace hvac_twin::est;

namespace {

// Mean and variance of N(0, 1) restricted to (-inf, c], by Simpson's rule over
// [c - 30 / (1 + |c|) - 12, c] in long double.
std::pair<double, double> truncated_by_integration(double c_double) {
  const auto c = static_cast<long double>(c_double);
  const long double lo = c - 12.0L - 30.0L / (1.0L + std::fabs(c)), hi = c;
  const int n = 200000;
  const long double h = (hi - lo) / n;
  long double m0 = 0, m1 = 0, m2 = 0;
  for (int i = 0; i <= n; ++i) {
    const long double t = lo + h * i;
    const long double w = (i == 0 || i == n) ? 1 : (i % 2 ? 4 : 2);
    const long double f = std::exp(-0.5L * t * t);
    m0 += w * f;
    m1 += w * t * f;
    m2 += w * t * t * f;
  }
  const long double mean = m1 / m0;
  return {static_cast<double>(mean), static_cast<double>(m2 / m0 - mean * mean)};
}

}  // namespace

TEST_CASE("truncated standard normal moments match numerical integration", "[truncation]") {
  for (double c : {-40.0, -30.0001, -29.9999, -20.0, -8.0, -4.0, -1.5, 0.0, 1.0, 3.0, 6.0}) {
    INFO("c = " << c);
    const auto t = truncated_standard_normal(c);
    const auto [mean, var] = truncated_by_integration(c);
    CHECK(t.mean == Approx(mean).epsilon(1e-6).margin(1e-9));
    CHECK(t.variance == Approx(var).epsilon(1e-4));
    CHECK(t.variance > 0.0);
    CHECK(t.variance <= 1.0);
  }
  // Nothing to truncate far above the mean.
  CHECK(truncated_standard_normal(50.0).mean == 0.0);
  CHECK(truncated_standard_normal(50.0).variance == 1.0);
}

TEST_CASE("Gaussian truncation of a correlated 2-D Gaussian matches grid integration",
          "[truncation]") {
  Eigen::Vector2d x(1.0, -0.5);
  Eigen::Matrix2d P;
  P << 2.0, 0.8, 0.8, 1.0;
  const Eigen::Vector2d a(1.0, 2.0);
  const double b = 0.2;  // a'x = 0 <= b: a constraint through the bulk of the density
  // Reference: moments of the density restricted to a'x <= b, by the midpoint rule on a grid
  // aligned with the constraint (p = s e1 + t e2, e1 = a/|a|), whose edge is exactly s = b/|a|.
  const Eigen::Matrix2d Pi = P.inverse();
  const Eigen::Vector2d e1 = a.normalized(), e2(-e1(1), e1(0));
  const double s_max = b / a.norm(), h = 0.005;
  double w = 0, m1x = 0, m1y = 0, sxx = 0, sxy = 0, syy = 0;
  for (double s = s_max - h / 2; s > s_max - 14.0; s -= h)
    for (double t = -14.0 + h / 2; t < 14.0; t += h) {
      const Eigen::Vector2d p = s * e1 + t * e2;
      const Eigen::Vector2d d = p - x;
      const double f = std::exp(-0.5 * d.dot(Pi * d));
      const double u = p(0), v = p(1);
      w += f;
      m1x += f * u;
      m1y += f * v;
      sxx += f * u * u;
      sxy += f * u * v;
      syy += f * v * v;
    }
  const double mx = m1x / w, my = m1y / w;
  Eigen::Vector2d xt = x;
  Eigen::Matrix2d Pt = P;
  Eigen::Vector2d work;
  REQUIRE(truncate_gaussian(xt, Pt, a, b, work, std::numeric_limits<double>::infinity()));
  CHECK(xt(0) == Approx(mx).epsilon(1e-5));
  CHECK(xt(1) == Approx(my).epsilon(1e-5));
  CHECK(Pt(0, 0) == Approx(sxx / w - mx * mx).epsilon(1e-5));
  CHECK(Pt(0, 1) == Approx(sxy / w - mx * my).epsilon(1e-5));
  CHECK(Pt(1, 1) == Approx(syy / w - my * my).epsilon(1e-5));
  CHECK(a.dot(xt) < b);  // the mean moved inside
}

namespace {

// Brute force: every subset S of constraints, the equality-constrained projection onto S, kept
// if feasible with non-negative multipliers (KKT); the best such point.
Eigen::VectorXd brute_force(const Eigen::VectorXd& x0, const Eigen::MatrixXd& P,
                            const Eigen::MatrixXd& A, const Eigen::VectorXd& b, int& active) {
  const int m = static_cast<int>(A.rows());
  const Eigen::MatrixXd Pi = P.inverse();
  double best = std::numeric_limits<double>::infinity();
  Eigen::VectorXd best_x = x0;
  for (int mask = 0; mask < (1 << m); ++mask) {
    std::vector<int> S;
    for (int i = 0; i < m; ++i)
      if (mask & (1 << i)) S.push_back(i);
    Eigen::VectorXd x = x0;
    Eigen::VectorXd lambda;
    if (!S.empty()) {
      Eigen::MatrixXd AS(S.size(), A.cols());
      Eigen::VectorXd bS(S.size());
      for (std::size_t i = 0; i < S.size(); ++i) {
        AS.row(static_cast<Eigen::Index>(i)) = A.row(S[i]);
        bS(static_cast<Eigen::Index>(i)) = b(S[i]);
      }
      const Eigen::MatrixXd G = AS * P * AS.transpose();
      if (std::abs(G.determinant()) < 1e-12) continue;
      lambda = G.ldlt().solve(AS * x0 - bS);
      if ((lambda.array() < -1e-10).any()) continue;
      x = x0 - P * AS.transpose() * lambda;
    }
    if (((A * x - b).array() > 1e-9).any()) continue;
    const double f = (x - x0).dot(Pi * (x - x0));
    if (f < best) {
      best = f;
      best_x = x;
      active = static_cast<int>((lambda.array() > 1e-10).count());
    }
  }
  return best_x;
}

}  // namespace

TEST_CASE("the QP projection equals brute-force enumeration of active sets", "[qp]") {
  std::mt19937 rng(17);
  std::normal_distribution<double> g(0.0, 1.0);
  int with_active = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const int n = 2 + trial % 4, m = 2 + trial % 5;
    Eigen::MatrixXd R(n, n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        R(i, j) = g(rng);
    const Eigen::MatrixXd P = R * R.transpose() + 0.1 * Eigen::MatrixXd::Identity(n, n);
    Eigen::MatrixXd A(m, n);
    Eigen::VectorXd b(m), x0(n), scale = Eigen::VectorXd::Ones(m);
    for (int i = 0; i < m; ++i) {
      for (int j = 0; j < n; ++j)
        A(i, j) = g(rng);
      b(i) = 0.5 + std::abs(g(rng));  // the origin is feasible: the problem always is
    }
    for (int j = 0; j < n; ++j)
      x0(j) = 2.0 * g(rng);
    int expected_active = 0;
    const Eigen::VectorXd expected = brute_force(x0, P, A, b, expected_active);

    ConstrainedProjection qp(static_cast<std::size_t>(n), static_cast<std::size_t>(m));
    Eigen::VectorXd x = x0;
    const auto r = qp.solve(x, P, A, b, scale, static_cast<std::size_t>(m));
    INFO("trial " << trial << " n " << n << " m " << m);
    REQUIRE(r.converged);
    CHECK((x - expected).norm() < 1e-8 * (1.0 + expected.norm()));
    CHECK(static_cast<int>(r.active) == expected_active);
    for (std::size_t k = 0; k < r.active; ++k)
      CHECK(qp.multiplier(k) > 0.0);
    CHECK(((A * x - b).array() <= 1e-9).all());
    with_active += r.active > 0;
  }
  CHECK(with_active > 100);  // the trials exercise active constraints, not only the trivial case
}

TEST_CASE("the QP leaves a feasible point alone and reports no active constraint", "[qp]") {
  const Eigen::MatrixXd P = Eigen::MatrixXd::Identity(3, 3);
  Eigen::MatrixXd A = Eigen::MatrixXd::Identity(3, 3);
  const Eigen::VectorXd b = Eigen::VectorXd::Ones(3), scale = Eigen::VectorXd::Ones(3);
  Eigen::VectorXd x(3);
  x << 0.5, -2.0, 1.0;  // on the boundary of x2 <= 1: not violated
  ConstrainedProjection qp(3, 3);
  const Eigen::VectorXd before = x;
  const auto r = qp.solve(x, P, A, b, scale, 3);
  CHECK(r.converged);
  CHECK(r.active == 0);
  CHECK(x == before);
}

TEST_CASE("box constraints in a correlated metric move the other states too", "[qp]") {
  // x1 <= 0 with x0 = (1, 1) and strong correlation: the projection lowers x2 as well.
  Eigen::MatrixXd P(2, 2);
  P << 1.0, 0.9, 0.9, 1.0;
  Eigen::MatrixXd A(1, 2);
  A << 1.0, 0.0;
  const Eigen::VectorXd b = Eigen::VectorXd::Zero(1), scale = Eigen::VectorXd::Ones(1);
  Eigen::VectorXd x(2);
  x << 1.0, 1.0;
  ConstrainedProjection qp(2, 1);
  const auto r = qp.solve(x, P, A, b, scale, 1);
  REQUIRE(r.converged);
  CHECK(r.active == 1);
  CHECK(qp.active()[0] == 0);
  CHECK(x(0) == Approx(0.0).margin(1e-12));
  CHECK(x(1) == Approx(1.0 - 0.9).epsilon(1e-12));  // conditional mean: x2 - P21/P11 * 1
}

// --- The constrained EKF ---------------------------------------------------------------------

#include "daemon/estimation/ekf.hpp"
#include "plant_models/core/ad_model.hpp"
#include "test_models.hpp"

namespace {

struct UnitInterval : hvac_twin::test::RandomWalk {
  hvac_twin::plant::ModelLayout layout() const {
    auto l = RandomWalk::layout();
    l.states[0].min = 0.0;
    l.states[0].max = 1.0;
    return l;
  }
};

}  // namespace

TEST_CASE("the constrained EKF projects onto a violated bound and truncates the covariance",
          "[ekf][constrained]") {
  const hvac_twin::plant::AdModel<UnitInterval> model{UnitInterval{}};
  EkfOptions options;
  options.constrained = true;
  Ekf constrained(model, std::vector<double>{0.0}, 1, options);
  options.constrained = false;
  Ekf plain(model, std::vector<double>{0.0}, 1, options);
  for (Ekf* f : {&constrained, &plain})
    f->reset(std::vector<double>{0.9}, std::vector<double>{0.2});
  const Measurement m{.output = 0, .value = 1.3, .variance = 0.01, .available = true};
  MeasurementReport rep;
  REQUIRE(plain.update({&m, 1}, {}, {&rep, 1}) == StepStatus::kOk);
  REQUIRE(constrained.update({&m, 1}, {}, {&rep, 1}) == StepStatus::kOk);
  const double x_plain = plain.state()(0), p_plain = plain.covariance()(0, 0);
  CHECK(x_plain > 1.0);  // the unconstrained estimate leaves the physical range
  CHECK(constrained.state()(0) == Approx(1.0).margin(1e-12));  // the MAP on the bound
  // Covariance: the unconstrained posterior truncated at x <= 1, in closed form, believed at
  // most truncation_max_depth (1) sigma beyond the bound: it lies 2.5 sigma beyond.
  const double sigma = std::sqrt(p_plain), c = (1.0 - x_plain) / sigma;
  REQUIRE(c < -2.0);
  const auto limited = truncated_standard_normal(-1.0);
  CHECK(constrained.covariance()(0, 0) == Approx(p_plain * limited.variance).epsilon(1e-12));
  CHECK(constrained.covariance()(0, 0) < p_plain);
  // Without the limit: the exact truncated variance, a third of the limited one.
  options.constrained = true;
  options.truncation_max_depth = std::numeric_limits<double>::infinity();
  Ekf exact(model, std::vector<double>{0.0}, 1, options);
  exact.reset(std::vector<double>{0.9}, std::vector<double>{0.2});
  REQUIRE(exact.update({&m, 1}, {}, {&rep, 1}) == StepStatus::kOk);
  CHECK(exact.state()(0) == Approx(1.0).margin(1e-12));
  CHECK(exact.covariance()(0, 0) ==
        Approx(p_plain * truncated_standard_normal(c).variance).epsilon(1e-12));
  CHECK(exact.covariance()(0, 0) < 0.5 * constrained.covariance()(0, 0));
  REQUIRE(constrained.active_constraints().size() == 1);
  CHECK_THAT(constrained.constraint_name(constrained.active_constraints()[0]),
             Catch::StartsWith("x <= 1"));
  CHECK(constrained.counters().constrained_updates == 1);
}

TEST_CASE("the truncation's depth limit: a mean far beyond the bound is believed only so far",
          "[truncation]") {
  // N(5, 1) truncated to x <= 0: exact, the variance ~1/25 (the tail's shape); limited to 1
  // sigma, that of N(1, 1) truncated to x <= 0, on every correlated state alike.
  Eigen::Vector2d a(1.0, 0.0), work;
  Eigen::Matrix2d P;
  P << 1.0, 0.6, 0.6, 2.0;
  for (const double depth : {std::numeric_limits<double>::infinity(), 1.0, 6.0}) {
    INFO("max depth " << depth);
    Eigen::Vector2d x(5.0, 0.0);
    Eigen::Matrix2d Pt = P;
    REQUIRE(truncate_gaussian(x, Pt, a, 0.0, work, depth));
    const double v = truncated_standard_normal(std::max(-5.0, -depth)).variance;
    CHECK(Pt(0, 0) == Approx(v).epsilon(1e-12));
    // The correlated state loses the same share of what it shares with x0.
    CHECK(Pt(1, 1) == Approx(2.0 - 0.36 * (1.0 - v)).epsilon(1e-12));
  }
  CHECK(truncated_standard_normal(-5.0).variance < 0.04);
  CHECK(truncated_standard_normal(-1.0).variance > 0.19);
}

TEST_CASE("with no constraint active the constrained EKF equals the plain one",
          "[ekf][constrained]") {
  const hvac_twin::plant::AdModel<UnitInterval> model{UnitInterval{}};
  EkfOptions options;
  options.constrained = true;
  Ekf constrained(model, std::vector<double>{0.01}, 1, options);
  options.constrained = false;
  Ekf plain(model, std::vector<double>{0.01}, 1, options);
  for (Ekf* f : {&constrained, &plain})
    f->reset(std::vector<double>{0.5}, std::vector<double>{0.1});
  for (double z : {0.4, 0.55, 0.6, 0.45}) {
    const Measurement m{.output = 0, .value = z, .variance = 0.01, .available = true};
    MeasurementReport rep;
    for (Ekf* f : {&constrained, &plain}) {
      REQUIRE(f->predict({}, 1.0) == StepStatus::kOk);
      REQUIRE(f->update({&m, 1}, {}, {&rep, 1}) == StepStatus::kOk);
    }
    CHECK(constrained.state()(0) == plain.state()(0));
    CHECK(constrained.covariance()(0, 0) == plain.covariance()(0, 0));
    CHECK(constrained.active_constraints().empty());
  }
}
