// Single-phase density from (p, T) and the (p, h) flash of the R32 EOS.
//
// Both are safeguarded Newton iterations inside a bracket on a branch of the EOS along which
// p rises with rho: a Newton step that leaves the bracket (or meets dp/drho <= 0) is replaced by
// bisection, and the bracket shrinks with the sign of the residual, so the iteration cannot
// wander onto another branch. The (p, h) flash nests the density solve inside a Newton
// iteration on T (slope cp, which is positive on a stable branch).
#include <algorithm>
#include <cmath>

#include "plant_models/refrigerant/r32_ancillary.hpp"
#include "plant_models/refrigerant/r32_eos.hpp"

namespace hvac_twin::plant::r32 {
namespace {

constexpr double kRhoMax = 2000.0;  // kg/m^3, far above any state of the EOS range
constexpr double kTHigh = 1.2 * kTmaxEos;
constexpr double kTLow = kTtriple - 1.0;
constexpr int kMaxIter = 200;

// rho with p(T, rho) = p on [lo, hi]; requires p(T, lo) <= p <= p(T, hi) unless the Newton
// iteration from rho0 converges first. Returns kOk only at a mechanically stable root.
Status solve_density(double p, double T, double rho0, double lo, double hi, double& rho) {
  const double tau = kTc / T;
  rho = std::clamp(rho0, lo, hi);
  if (!(rho > 0.0)) rho = 0.5 * (lo + hi);
  for (int it = 0; it < kMaxIter; ++it) {
    const Helmholtz a = helmholtz(rho / kRhoc, tau);
    const double f = rho * kR * T * (1.0 + a.d_ar_d) - p;
    const double dp = kR * T * (1.0 + 2.0 * a.d_ar_d + a.dd_ar_dd);
    if (f < 0.0) {
      lo = rho;
    } else {
      hi = rho;
    }
    if (std::abs(f) <= 1e-14 * p) return dp > 0.0 ? Status::kOk : Status::kNotConverged;
    double next = rho - f / dp;
    if (!(dp > 0.0) || !(next > lo && next < hi)) next = 0.5 * (lo + hi);
    const bool tiny = std::abs(next - rho) <= 1e-14 * rho;
    rho = next;
    if (tiny) return dp > 0.0 ? Status::kOk : Status::kNotConverged;
  }
  return Status::kNotConverged;
}

// Lowest density at which the liquid branch of the isotherm T is certainly mechanically stable
// with p(T, rho) <= p_sat(T): 1 % below the ancillary saturated-liquid density (its error is
// < 0.3 %). Below it, at low T, the EOS surface inside the spinodal is wild (p of +-1e10 Pa),
// so a bracket must never reach there. 0 above Tc (p rises monotonically with rho).
double liquid_floor(double T) {
  return T < kTc ? 0.99 * ancillary::rho_liquid(T) : 0.0;
}

}  // namespace

DensityResult density_pt(double p, double T) {
  DensityResult out;
  if (!(p > 0.0 && p <= kPmaxEos && T >= kTLow && T <= kTHigh)) {
    out.status = Status::kOutOfRange;
    return out;
  }
  if (T >= kTc || p >= kPc) {
    out.phase = p >= kPc ? Phase::kSupercritical : Phase::kVapour;
    const double guess = T < kTc ? ancillary::rho_liquid(T) : p / (kR * T);
    out.status = solve_density(p, T, guess, liquid_floor(T), kRhoMax, out.rho);
    return out;
  }
  const Saturation sat = saturation_t(T);
  if (sat.status != Status::kOk) {
    out.status = sat.status;
    return out;
  }
  if (p >= sat.p) {
    out.phase = Phase::kLiquid;
    out.status = solve_density(p, T, sat.liquid.rho, sat.liquid.rho, kRhoMax, out.rho);
  } else {
    out.phase = Phase::kVapour;
    const double guess = std::min(p / (kR * T), sat.vapour.rho);
    out.status = solve_density(p, T, guess, 0.0, sat.vapour.rho, out.rho);
  }
  return out;
}

FlashResult flash_ph_branch(double p, double h, const Bracket& b, double T_guess,
                            double rho_guess) {
  FlashResult out;
  double T_lo = b.T_lo;
  double T_hi = b.T_hi;
  double T = std::clamp(T_guess, T_lo, T_hi);
  double rho = rho_guess;
  const double tol = 1e-13 * std::max(std::abs(h), 1e4);
  for (int it = 0; it < kMaxIter; ++it) {
    const double lo = b.liquid_like ? std::max(b.rho_lo, liquid_floor(T)) : b.rho_lo;
    const Status st = solve_density(p, T, rho, lo, b.rho_hi, rho);
    if (st != Status::kOk) {
      out.status = st;
      return out;
    }
    const Properties s = properties_trho(T, rho);
    const double f = s.h - h;
    if (f > 0.0) {
      T_hi = T;
    } else {
      T_lo = T;
    }
    if (std::abs(f) <= tol) {
      out.status = Status::kOk;
      break;
    }
    double next = T - f / s.cp;
    if (!(s.cp > 0.0) || !(next > T_lo && next < T_hi)) next = 0.5 * (T_lo + T_hi);
    if (std::abs(next - T) <= 1e-14 * T) {
      // Converged in T; h cannot be matched closer than its rounding, or the root lies on the
      // bracket end (h outside the branch): tell the two apart by the residual.
      out.status =
          std::abs(f) <= 1e-9 * std::max(std::abs(h), 1e4) ? Status::kOk : Status::kOutOfRange;
      break;
    }
    T = next;
  }
  out.T = T;
  out.rho = rho;
  return out;
}

FlashResult flash_ph(double p, double h) {
  FlashResult out;
  if (!(p > 0.0 && p <= kPmaxEos && std::isfinite(h))) {
    out.status = Status::kOutOfRange;
    return out;
  }
  if (p >= kPc) {
    const Bracket b{kTLow, kTHigh, 0.0, kRhoMax, true};
    out = flash_ph_branch(p, h, b, kTc, kRhoc);
    out.phase = Phase::kSupercritical;
    out.quality = out.T < kTc ? -1.0 : 2.0;
    return out;
  }
  const Saturation sat = saturation_p(p);
  if (sat.status != Status::kOk) {
    out.status = sat.status;
    return out;
  }
  const Properties& l = sat.liquid;
  const Properties& v = sat.vapour;
  const double x = (h - l.h) / (v.h - l.h);
  if (x >= 0.0 && x <= 1.0) {
    out.status = Status::kOk;
    out.phase = Phase::kTwoPhase;
    out.T = sat.T;
    out.rho = 1.0 / (x / v.rho + (1.0 - x) / l.rho);
  } else if (x < 0.0) {
    const Bracket b{kTLow, sat.T, l.rho, kRhoMax, true};
    const double T0 = sat.T + (h - l.h) / l.cp;
    out = flash_ph_branch(p, h, b, T0, l.rho);
    out.phase = Phase::kLiquid;
  } else {
    const Bracket b{sat.T, kTHigh, 0.0, v.rho, false};
    const double T0 = sat.T + (h - v.h) / v.cp;
    out = flash_ph_branch(p, h, b, T0, v.rho * sat.T / T0);
    out.phase = Phase::kVapour;
  }
  out.quality = x;
  return out;
}

}  // namespace hvac_twin::plant::r32
