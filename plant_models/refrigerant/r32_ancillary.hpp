// Ancillary equations of the R32 saturation curve (starting values for the EOS solvers only;
// see data/r32_eos.json "ancillaries_CoolProp" for their accuracy). Internal header.
// Units: K, Pa, kg/m^3. Pure functions, no allocation.
#pragma once

#include <algorithm>
#include <cmath>

#include "plant_models/refrigerant/r32_coefficients.hpp"
#include "plant_models/refrigerant/r32_eos.hpp"

namespace hvac_twin::plant::r32::ancillary {

inline constexpr double kPtripleApprox = 47.0;  // Pa; the EOS gives 47.9999 Pa at T_triple

template <std::size_t N>
double theta_sum(double theta, const std::array<double, N>& n, const std::array<double, N>& t) {
  double sum = 0.0;
  for (std::size_t i = 0; i < N; ++i)
    sum += n[i] * std::pow(theta, t[i]);
  return sum;
}

inline double p_sat(double T) {
  const double theta = std::max(1.0 - T / kTc, 0.0);
  return kPc * std::exp(kTc / T * theta_sum(theta, coeff::kPsN, coeff::kPsT));
}
inline double rho_liquid(double T) {
  const double theta = std::max(1.0 - T / kTc, 0.0);
  return kRhoc * (1.0 + theta_sum(theta, coeff::kRhoLN, coeff::kRhoLT));
}
inline double rho_vapour(double T) {
  const double theta = std::max(1.0 - T / kTc, 0.0);
  return kRhoc * std::exp(kTc / T * theta_sum(theta, coeff::kRhoVN, coeff::kRhoVT));
}

// Inverse of p_sat by bisection on T to 1e-9 K (p_sat is monotone). p in (kPtripleApprox, kPc).
inline double t_sat(double p) {
  const double lnp = std::log(p);
  double lo = kTtriple - 1.0;
  double hi = kTc;
  for (int it = 0; it < 60 && hi - lo > 1e-9; ++it) {
    const double mid = 0.5 * (lo + hi);
    if (std::log(p_sat(mid)) < lnp) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return std::min(0.5 * (lo + hi), kTc - 1e-7);
}

}  // namespace hvac_twin::plant::r32::ancillary
