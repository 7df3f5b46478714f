#include "plant_models/core/matrix_exponential.hpp"

#include <array>
#include <cmath>

namespace hvac_twin::plant {
namespace {

// Higham (2005), table 2.3: the [13/13] Padé coefficients b_0..b_13 and theta_13.
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
constexpr double kTheta13 = 5.371920351148152;
constexpr int kMaxSquarings = 60;  // 1-norm up to 5e18; beyond that A is not a model's
constexpr int kMaxBalanceSweeps = 10;

}  // namespace

MatrixExponential::MatrixExponential(Eigen::Index n)
    : a_(n, n), a2_(n, n), a4_(n, n), a6_(n, n), u_(n, n), v_(n, n), t_(n, n), d_(n), lu_(n) {}

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

bool MatrixExponential::compute(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                Eigen::Ref<Eigen::MatrixXd> out) {
  if (!A.allFinite()) return false;
  a_ = A;
  balance();                                                     // a_ = D^-1 A D
  const double norm = a_.cwiseAbs().colwise().sum().maxCoeff();  // 1-norm
  int s = 0;
  if (norm > kTheta13) s = static_cast<int>(std::ceil(std::log2(norm / kTheta13)));
  if (s > kMaxSquarings) return false;
  squarings_ = s;
  a_ *= std::ldexp(1.0, -s);
  a2_.noalias() = a_ * a_;
  a4_.noalias() = a2_ * a2_;
  a6_.noalias() = a4_ * a2_;
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
  // r13 = (V - U)^-1 (V + U)
  t_ = v_ - u_;
  lu_.compute(t_);
  if (!(lu_.matrixLU().diagonal().cwiseAbs().minCoeff() > 0.0)) return false;
  t_ = v_ + u_;
  out = lu_.solve(t_);
  for (int k = 0; k < s; ++k) {
    t_.noalias() = out * out;
    out = t_;
  }
  // exp(A) = D exp(D^-1 A D) D^-1, in place
  out.array().colwise() *= d_.array();
  out.array().rowwise() /= d_.transpose().array();
  return out.allFinite();
}

}  // namespace hvac_twin::plant
