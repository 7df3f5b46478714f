// Vapour-liquid equilibrium of the R32 EOS: equal temperature, pressure and Gibbs energy.
//
// At given T: Newton on (delta_L, delta_V) in the formulation of Akasaka (J. Thermal Sci. Tech.
// 3, 442 (2008)): J(delta) = delta (1 + delta alphar_delta) (reduced pressure) and
// K(delta) = delta alphar_delta + alphar + ln(delta) (reduced Gibbs energy) must be equal in both
// phases; started from the ancillary equations, with step halving that keeps
// 0 < delta_V < delta_L. At given p: Newton on T with the Clapeyron slope
// d ln p / dT = (h_V - h_L) / (T (v_V - v_L) p), each step a saturation solve at T.
#include <algorithm>
#include <cmath>

#include "plant_models/refrigerant/r32_ancillary.hpp"
#include "plant_models/refrigerant/r32_eos.hpp"

namespace hvac_twin::plant::r32 {
namespace {

constexpr double kTsatLow = kTtriple - 1.0;  // a little below the triple point for bracketing
constexpr int kMaxIter = 100;

// Along-saturation derivatives with respect to p from the Clapeyron equation and the
// single-phase surface of each phase.
void add_saturation_derivatives(Saturation& s) {
  const Properties& l = s.liquid;
  const Properties& v = s.vapour;
  s.dT_dp = s.T * (1.0 / v.rho - 1.0 / l.rho) / (v.h - l.h);
  auto along = [&](const Properties& x, double& dh_dp, double& drho_dp) {
    const double drho_dp_T = 1.0 / x.dp_drho_T;
    const double drho_dT_p = -x.dp_dT_rho / x.dp_drho_T;
    const double dh_dp_T = x.dh_drho_T / x.dp_drho_T;
    drho_dp = drho_dp_T + drho_dT_p * s.dT_dp;
    dh_dp = dh_dp_T + x.cp * s.dT_dp;
  };
  along(l, s.dh_l_dp, s.drho_l_dp);
  along(v, s.dh_v_dp, s.drho_v_dp);
}

Saturation saturation_t_from(double T, double dL, double dV) {
  Saturation out;
  out.T = T;
  if (!(T >= kTsatLow && T < kTc)) {
    out.status = Status::kOutOfRange;
    return out;
  }
  const double tau = kTc / T;
  bool converged = false;
  for (int it = 0; it < kMaxIter && !converged; ++it) {
    const Helmholtz aL = helmholtz(dL, tau);
    const Helmholtz aV = helmholtz(dV, tau);
    const double JL = dL * (1.0 + aL.d_ar_d);
    const double JV = dV * (1.0 + aV.d_ar_d);
    const double KL = aL.d_ar_d + aL.ar + std::log(dL);
    const double KV = aV.d_ar_d + aV.ar + std::log(dV);
    const double JdL = 1.0 + 2.0 * aL.d_ar_d + aL.dd_ar_dd;
    const double JdV = 1.0 + 2.0 * aV.d_ar_d + aV.dd_ar_dd;
    const double KdL = JdL / dL;
    const double KdV = JdV / dV;
    const double F1 = JL - JV;
    const double F2 = KL - KV;
    // J_L carries a rounding error of ~1e-16 delta_L |delta alphar_delta|, which dominates J_V at
    // low T, so the residual test is relative to that scale.
    const double scale = std::abs(JV) + 1e-15 * dL * (1.0 + std::abs(aL.d_ar_d));
    if (std::abs(F1) <= 1e-13 * scale && std::abs(F2) <= 1e-13) {
      converged = true;
      break;
    }
    const double det = JdV * KdL - JdL * KdV;
    if (!(std::abs(det) > 0.0) || !std::isfinite(det)) break;
    double stepL = (F1 * KdV - JdV * F2) / det;
    double stepV = (KdL * F1 - JdL * F2) / det;
    // Step halving: stay physical (0 < dV < dL) and do not move vapour density by more than a
    // factor of two in one step.
    for (int k = 0; k < 40; ++k) {
      const double nL = dL + stepL;
      const double nV = dV + stepV;
      if (nV > 0.5 * dV && nV < 2.0 * dV && nL > nV && nL > 0.0) break;
      stepL *= 0.5;
      stepV *= 0.5;
    }
    dL += stepL;
    dV += stepV;
    // Quadratic convergence: a step this small leaves an error at the rounding level.
    if (std::abs(stepL) <= 1e-11 * dL && std::abs(stepV) <= 1e-11 * dV) converged = true;
  }
  // Reject the trivial solution (both phases identical) and non-convergence.
  if (!converged || !(dL > dV * (1.0 + 1e-9)) || !std::isfinite(dL) || !std::isfinite(dV)) {
    out.status = Status::kNotConverged;
    return out;
  }
  out.liquid = properties_trho(T, dL * kRhoc);
  out.vapour = properties_trho(T, dV * kRhoc);
  out.p = out.vapour.p;  // equal to out.liquid.p within ~1e-13 relative
  add_saturation_derivatives(out);
  out.status = Status::kOk;
  return out;
}

}  // namespace

Saturation saturation_t(double T) {
  if (!(T >= kTsatLow && T < kTc)) {
    Saturation out;
    out.T = T;
    out.status = Status::kOutOfRange;
    return out;
  }
  return saturation_t_from(T, ancillary::rho_liquid(T) / kRhoc, ancillary::rho_vapour(T) / kRhoc);
}

Saturation saturation_p(double p) {
  if (!(p >= ancillary::kPtripleApprox && p < kPc)) {
    Saturation out;
    out.p = p;
    out.status = Status::kOutOfRange;
    return out;
  }
  const double lnp = std::log(p);
  double T = ancillary::t_sat(p);
  Saturation s = saturation_t(T);
  for (int it = 0; it < kMaxIter; ++it) {
    if (s.status != Status::kOk) return s;
    const double f = std::log(s.p) - lnp;
    if (std::abs(f) <= 2e-15) break;
    const double dlnp_dT =
        (s.vapour.h - s.liquid.h) / (T * (1.0 / s.vapour.rho - 1.0 / s.liquid.rho) * s.p);
    double Tn = T - f / dlnp_dT;
    if (!(Tn < kTc)) Tn = 0.5 * (T + kTc);
    if (!(Tn >= kTsatLow)) Tn = 0.5 * (T + kTsatLow);
    const bool tiny = std::abs(Tn - T) <= 1e-13 * T;
    s = saturation_t_from(Tn, s.liquid.rho / kRhoc, s.vapour.rho / kRhoc);
    T = Tn;
    if (tiny) break;
  }
  return s;
}

}  // namespace hvac_twin::plant::r32
