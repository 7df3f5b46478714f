// Helmholtz energy of R32 and the single-phase property relations (see r32_eos.hpp).
// Coefficients: data/r32_eos.json ("helmholtz" block), Tillner-Roth & Yokozeki (1997).
#include "plant_models/refrigerant/r32_eos.hpp"

#include <array>
#include <cmath>

#include "plant_models/refrigerant/r32_coefficients.hpp"

namespace hvac_twin::plant::r32 {

Helmholtz helmholtz(double delta, double tau) {
  using namespace coeff;
  Helmholtz r;

  // Ideal part: ln(delta) + a1 + a2 tau + a3 ln(tau) + sum m_k ln(1 - exp(-theta_k tau)).
  r.a0 = std::log(delta) + kA1 + kA2 * tau + kA3 * std::log(tau);
  r.t_a0_t = kA2 * tau + kA3;
  r.tt_a0_tt = -kA3;
  for (std::size_t k = 0; k < kM.size(); ++k) {
    const double x = kTheta[k] * tau;
    const double e = std::exp(-x);  // < 1 for tau > 0
    const double one_minus_e = 1.0 - e;
    r.a0 += kM[k] * std::log1p(-e);
    r.t_a0_t += kM[k] * x * e / one_minus_e;
    r.tt_a0_tt -= kM[k] * x * x * e / (one_minus_e * one_minus_e);
  }

  // Residual part: sum n_i delta^d_i tau^t_i exp(-delta^l_i).
  std::array<double, 9> dpow{};
  dpow[0] = 1.0;
  for (std::size_t i = 1; i < dpow.size(); ++i)
    dpow[i] = dpow[i - 1] * delta;
  const double ltau = std::log(tau);
  for (std::size_t i = 0; i < kN.size(); ++i) {
    const auto d = static_cast<double>(kD[i]);
    const double t = kT[i];
    double term = kN[i] * dpow[static_cast<std::size_t>(kD[i])] * std::exp(t * ltau);
    double ldl = 0.0;  // l * delta^l
    if (kL[i] > 0) {
      const double dl = dpow[static_cast<std::size_t>(kL[i])];
      term *= std::exp(-dl);
      ldl = static_cast<double>(kL[i]) * dl;
    }
    const double a = d - ldl;  // delta * d/ddelta of ln(term)
    r.ar += term;
    r.d_ar_d += term * a;
    r.dd_ar_dd += term * (a * (a - 1.0) - static_cast<double>(kL[i]) * ldl);
    r.t_ar_t += term * t;
    r.tt_ar_tt += term * t * (t - 1.0);
    r.dt_ar_dt += term * t * a;
  }
  return r;
}

double pressure_trho(double T, double rho) {
  // Only delta * dalphar/ddelta is needed; reuse the full evaluation for simplicity.
  const Helmholtz a = helmholtz(rho / kRhoc, kTc / T);
  return rho * kR * T * (1.0 + a.d_ar_d);
}

Properties properties_trho(double T, double rho) {
  const Helmholtz a = helmholtz(rho / kRhoc, kTc / T);
  Properties s;
  s.T = T;
  s.rho = rho;
  const double RT = kR * T;
  const double tt = a.tt_a0_tt + a.tt_ar_tt;           // tau^2 alpha_tautau (< 0)
  const double A = 1.0 + a.d_ar_d - a.dt_ar_dt;        // (dp/dT)_rho / (rho R)
  const double B = 1.0 + 2.0 * a.d_ar_d + a.dd_ar_dd;  // (dp/drho)_T / (R T)
  s.p = rho * RT * (1.0 + a.d_ar_d);
  s.h = RT * (1.0 + a.t_a0_t + a.t_ar_t + a.d_ar_d);
  s.s = kR * (a.t_a0_t + a.t_ar_t - a.a0 - a.ar);
  s.u = RT * (a.t_a0_t + a.t_ar_t);
  s.g = RT * (1.0 + a.a0 + a.ar + a.d_ar_d);
  s.cv = -kR * tt;
  s.cp = s.cv + kR * A * A / B;
  const double w2 = RT * (B - A * A / tt);
  s.w = w2 > 0.0 ? std::sqrt(w2) : 0.0;
  s.dp_drho_T = RT * B;
  s.dp_dT_rho = rho * kR * A;
  s.dh_dT_rho = kR * (A - tt);
  s.dh_drho_T = RT / rho * (a.dt_ar_dt + a.d_ar_d + a.dd_ar_dd);
  return s;
}

PhDerivatives ph_derivatives(const Properties& s) {
  // [dp; dh] = J [dT; drho] with J = [[p_T, p_rho], [h_T, h_rho]]; invert.
  const double det = s.dp_dT_rho * s.dh_drho_T - s.dp_drho_T * s.dh_dT_rho;
  PhDerivatives d;
  d.dT_dp_h = s.dh_drho_T / det;
  d.dT_dh_p = -s.dp_drho_T / det;
  d.drho_dp_h = -s.dh_dT_rho / det;
  d.drho_dh_p = s.dp_dT_rho / det;
  return d;
}

}  // namespace hvac_twin::plant::r32
