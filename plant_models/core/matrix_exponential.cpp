#include "plant_models/core/matrix_exponential.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace hvac_twin::plant {
namespace {

// Higham (2005), table 2.3: the Padé coefficients b_0..b_m of degree m, each row scaled so that
// b_m = 1 (b_j proportional to (2m - j)! m! / ((2m)! j! (m - j)!)), and the thetas.
constexpr std::array<double, 4> kB3{120.0, 60.0, 12.0, 1.0};
constexpr std::array<double, 6> kB5{30240.0, 15120.0, 3360.0, 420.0, 30.0, 1.0};
constexpr std::array<double, 8> kB7{17297280.0, 8648640.0, 1995840.0, 277200.0,
                                    25200.0,    1512.0,    56.0,      1.0};
constexpr std::array<double, 10> kB9{17643225600.0, 8821612800.0, 2075673600.0, 302702400.0,
                                     30270240.0,    2162160.0,    110880.0,     3960.0,
                                     90.0,          1.0};
constexpr std::array<double, 14> kB{64764752532480000.0,
                                    32382376266240000.0,
                                    7771770303897600.0,
                                    1187353796428800.0,
                                    129060195264000.0,
                                    10559470521600.0,
                                    670442572800.0,
                                    33522128640.0,
                                    1323241920.0,
                                    40840800.0,
                                    960960.0,
                                    16380.0,
                                    182.0,
                                    1.0};
constexpr double kTheta3 = 1.495585217958292e-2;
constexpr double kTheta5 = 2.539398330063230e-1;
constexpr double kTheta7 = 9.504178996162932e-1;
constexpr double kTheta9 = 2.097847961257068;
// Al-Mohy and Higham (2009), algorithm 5.1, scale the degree-13 approximant to 4.25 rather than
// the 2005 algorithm's 5.37.
constexpr double kTheta13 = 4.25;
constexpr int kMaxSquarings = 60;  // d_k up to 5e18; beyond that A is not a model's
constexpr int kMaxBalanceSweeps = 10;

// |c_(2m+1)| = (m!)^2 / ((2m)! (2m+1)!): the leading coefficient of exp(x) - r_m(x).
double leading_error(int m) {
  double m_factorial = 1.0, two_m_factorial = 1.0;
  for (int k = 1; k <= m; ++k)
    m_factorial *= k;
  for (int k = 1; k <= 2 * m; ++k)
    two_m_factorial *= k;
  return m_factorial * m_factorial / (two_m_factorial * two_m_factorial * (2 * m + 1));
}

double one_norm(const Eigen::MatrixXd& m) {
  return m.cwiseAbs().colwise().sum().maxCoeff();
}

}  // namespace

MatrixExponential::MatrixExponential(Eigen::Index n)
    : a_(n, n),
      a2_(n, n),
      a4_(n, n),
      a6_(n, n),
      u_(n, n),
      v_(n, n),
      t_(n, n),
      d_(n),
      w_(n),
      w2_(n),
      lu_(n) {}

void MatrixExponential::balance() {
  const Eigen::Index n = a_.rows();
  d_.setOnes();
  for (int sweep = 0; sweep < kMaxBalanceSweeps; ++sweep) {
    bool changed = false;
    for (Eigen::Index i = 0; i < n; ++i) {
      double c = a_.col(i).cwiseAbs().sum() - std::abs(a_(i, i));
      double r = a_.row(i).cwiseAbs().sum() - std::abs(a_(i, i));
      if (c == 0.0 || r == 0.0) continue;
      const double before = c + r;
      double f = 1.0;
      while (c < 0.5 * r) {
        c *= 2.0;
        r *= 0.5;
        f *= 2.0;
      }
      while (c >= 2.0 * r) {
        c *= 0.5;
        r *= 2.0;
        f *= 0.5;
      }
      if (c + r >= 0.95 * before) continue;
      changed = true;
      d_(i) *= f;
      a_.col(i) *= f;  // powers of two: exact
      a_.row(i) /= f;
    }
    if (!changed) break;
  }
}

int MatrixExponential::rounding_squarings(int m, double scale, double a_norm) {
  if (!(a_norm > 0.0)) return 0;
  // 1' |A|^k, normalised after each product (its largest entry is ||(|A|^k)||_1), in t_.
  t_ = scale * a_.cwiseAbs();
  w_.setOnes();
  double log2_norm = 0.0;
  for (int k = 0; k < 2 * m + 1; ++k) {
    w2_.noalias() = t_.transpose() * w_;
    const double largest = w2_.maxCoeff();
    if (!(largest > 0.0)) return 0;  // |A| nilpotent: no rounding error to bound
    w_ = w2_ / largest;
    log2_norm += std::log2(largest);
  }
  // alpha = |c_(2m+1)| || |A|^(2m+1) ||_1 / ||A||_1; ell = ceil(log2(alpha / u) / (2m)), u = 2^-53
  const double log2_alpha = std::log2(leading_error(m)) + log2_norm - std::log2(a_norm);
  const double ell = std::ceil((log2_alpha + 53.0) / (2.0 * m));
  return ell > 0.0 ? static_cast<int>(std::min(ell, 1.0 + kMaxSquarings)) : 0;
}

void MatrixExponential::low_degree(int m) {
  const double* b = m == 3 ? kB3.data() : m == 5 ? kB5.data() : m == 7 ? kB7.data() : kB9.data();
  const Eigen::MatrixXd* even[4] = {&a2_, &a4_, &a6_, &u_};  // A^2, A^4, A^6, A^8
  t_.setZero();
  v_.setZero();
  for (int k = 1; 2 * k <= m; ++k) {
    v_ += b[2 * k] * *even[k - 1];
    t_ += b[2 * k + 1] * *even[k - 1];
  }
  t_.diagonal().array() += b[1];
  v_.diagonal().array() += b[0];
  u_.noalias() = a_ * t_;  // U = A (b_m A^(m-1) + ... + b_1 I); V = b_(m-1) A^(m-1) + ... + b_0 I
}

bool MatrixExponential::compute(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                Eigen::Ref<Eigen::MatrixXd> out) {
  if (!A.allFinite()) return false;
  a_ = A;
  balance();  // a_ = D^-1 A D
  const double norm = one_norm(a_);
  // log2 of d_k = ||A^k||^(1/k), exact where A^k is computed, else an upper bound: in logarithms,
  // so that no product of norms overflows.
  a2_.noalias() = a_ * a_;
  const double l2 = std::log2(one_norm(a2_));
  squarings_ = 0;
  degree_ = 0;
  // Degree 3: max(d_4, d_6) <= d_2.
  if (l2 / 2.0 <= std::log2(kTheta3) && rounding_squarings(3, 1.0, norm) == 0) degree_ = 3;
  double l4 = 0.0, l6 = 0.0;
  if (degree_ == 0) {
    a4_.noalias() = a2_ * a2_;
    l4 = std::log2(one_norm(a4_));
    // Degree 5: max(d_4, d_6), d_6 <= (||A^2|| ||A^4||)^(1/6).
    if (std::max(l4 / 4.0, (l2 + l4) / 6.0) <= std::log2(kTheta5) &&
        rounding_squarings(5, 1.0, norm) == 0)
      degree_ = 5;
  }
  double eta3 = 0.0, l8 = 0.0;
  if (degree_ == 0) {
    a6_.noalias() = a4_ * a2_;
    l6 = std::log2(one_norm(a6_));
    l8 = std::min(l4 / 4.0, (l2 + l6) / 8.0);  // ||A^8|| <= ||A^4||^2, ||A^2|| ||A^6||
    eta3 = std::max(l6 / 6.0, l8);
    if (eta3 <= std::log2(kTheta7) && rounding_squarings(7, 1.0, norm) == 0) {
      degree_ = 7;
    } else if (eta3 <= std::log2(kTheta9) && rounding_squarings(9, 1.0, norm) == 0) {
      degree_ = 9;
      u_.noalias() = a4_ * a4_;
    }
  }
  if (degree_ != 0) {
    low_degree(degree_);
  } else {
    degree_ = 13;
    const double l10 = (l4 + l6) / 10.0;  // ||A^10|| <= ||A^4|| ||A^6||
    const double eta5 = std::min(eta3, std::max(l8, l10));
    if (std::isnan(eta5) || eta5 == std::numeric_limits<double>::infinity()) return false;
    int s = 0;
    if (eta5 > std::log2(kTheta13)) s = static_cast<int>(std::ceil(eta5 - std::log2(kTheta13)));
    if (s > kMaxSquarings) return false;
    s += rounding_squarings(13, std::ldexp(1.0, -s), std::ldexp(norm, -s));
    if (s > kMaxSquarings) return false;
    squarings_ = s;
    a_ *= std::ldexp(1.0, -s);
    a2_ *= std::ldexp(1.0, -2 * s);
    a4_ *= std::ldexp(1.0, -4 * s);
    a6_ *= std::ldexp(1.0, -6 * s);
    // U = A [A6 (b13 A6 + b11 A4 + b9 A2) + b7 A6 + b5 A4 + b3 A2 + b1 I]
    t_ = kB[13] * a6_ + kB[11] * a4_ + kB[9] * a2_;
    v_.noalias() = a6_ * t_;
    v_ += kB[7] * a6_ + kB[5] * a4_ + kB[3] * a2_;
    v_.diagonal().array() += kB[1];
    u_.noalias() = a_ * v_;
    // V = A6 (b12 A6 + b10 A4 + b8 A2) + b6 A6 + b4 A4 + b2 A2 + b0 I
    t_ = kB[12] * a6_ + kB[10] * a4_ + kB[8] * a2_;
    v_.noalias() = a6_ * t_;
    v_ += kB[6] * a6_ + kB[4] * a4_ + kB[2] * a2_;
    v_.diagonal().array() += kB[0];
  }
  // r_m = (V - U)^-1 (V + U)
  t_ = v_ - u_;
  lu_.compute(t_);
  if (!(lu_.matrixLU().diagonal().cwiseAbs().minCoeff() > 0.0)) return false;
  t_ = v_ + u_;
  out = lu_.solve(t_);
  for (int k = 0; k < squarings_; ++k) {
    t_.noalias() = out * out;
    out = t_;
  }
  // exp(A) = D exp(D^-1 A D) D^-1, in place
  out.array().colwise() *= d_.array();
  out.array().rowwise() /= d_.transpose().array();
  return out.allFinite();
}

}  // namespace hvac_twin::plant
