// Component equations of the heat pump, each written once over the scalar type (double or
// Dual<K>). Units SI: Pa, J/kg, kg/s, W, K differences. The smooth helpers replace kinks
// (max, sqrt at 0, phase switches) by documented smooth approximations so the model's
// right-hand side is differentiable where a solver will look.
#pragma once

#include <algorithm>
#include <cmath>

#include "plant_models/core/dual.hpp"
#include "plant_models/heat_pump/hp_params.hpp"

namespace hvac_twin::plant::hp {

inline constexpr double kAirCp = 1006.0;  // J/(kg K), dry air

// 1 / (1 + exp(-z)), without overflow for large |z|.
template <class S>
S logistic(const S& z) {
  using std::exp;
  if (value_of(z) >= 0.0) return 1.0 / (1.0 + exp(-z));
  const S e = exp(z);
  return e / (1.0 + e);
}

// max(x, floor) smoothed over `width` (softplus): within about 0.7 width of the kink only.
template <class S>
S smooth_floor(const S& x, double floor, double width) {
  using std::exp;
  using std::log1p;
  const S z = (x - floor) / width;
  if (value_of(z) > 30.0) return x;
  return floor + width * log1p(exp(z));
}

// sign(x) sqrt(|x|), regularised to be smooth through 0: x / (x^2 + eps^2)^(1/4). Equal to the
// signed square root for |x| >> eps; linear with slope 1/sqrt(eps) near 0.
template <class S>
S signed_sqrt(const S& x, double eps) {
  using std::sqrt;
  return x / sqrt(sqrt(x * x + eps * eps));
}

template <class S>
struct CompressorFlow {
  S mdot;    // kg/s
  S h_dis;   // J/kg, discharge enthalpy
  S w_ref;   // W, power to the refrigerant = mdot (h_dis - h_suc)
  S w_elec;  // W, electric
};

// Variable-speed compressor. Volumetric efficiency falls linearly with the pressure ratio
// (clearance re-expansion); isentropic efficiency is a paraboloid around the best pressure
// ratio and speed; the isentropic work is polytropic with exponent kappa (fits the R32 EOS
// within 1 % for suction 0.8-1.1 MPa, superheat 2-10 K, pressure ratio 2-3.5: see the tests).
template <class S>
CompressorFlow<S> compressor(const Params& P, const S& p_suc, const S& rho_suc, const S& h_suc,
                             const S& p_dis, double speed_hz) {
  using std::pow;
  const double f = std::max(speed_hz, 0.0);
  const S pi = p_dis / p_suc;
  const S eta_v = smooth_floor(S(P.eta_v0 - P.eta_v_slope * (pi - 1.0)), 0.05, 0.01);
  const double speed_dev = (f - P.speed_rated) / P.speed_rated;
  const S eta_is =
      smooth_floor(S(P.eta_is_peak - P.eta_is_pi_curv * (pi - P.pi_optimum) * (pi - P.pi_optimum) -
                     P.eta_is_speed_curv * speed_dev * speed_dev),
                   0.2, 0.01);
  const double k = P.kappa;
  const S dh_is = k / (k - 1.0) * p_suc / rho_suc * (pow(pi, (k - 1.0) / k) - 1.0);
  CompressorFlow<S> out;
  out.mdot = eta_v * rho_suc * (P.displacement * f);
  out.h_dis = h_suc + dh_is / eta_is;
  out.w_ref = out.mdot * (out.h_dis - h_suc);
  out.w_elec = out.w_ref / P.motor_efficiency;
  return out;
}

// Electronic expansion valve, isenthalpic: mdot = C a sqrt(2 rho_in dp), smooth through dp = 0
// (regularised over 1 kPa of dp at liquid density).
template <class S>
S valve_flow(const Params& P, double opening, const S& rho_in, const S& dp) {
  const double a = std::clamp(opening, 0.0, 1.0);
  return P.valve_coefficient * a * signed_sqrt(S(2.0 * rho_in * dp), 2.0 * 1000.0 * 1e3);
}

// Air side of a coil: the air crosses each of the N cells once in parallel, each taking
// air_flow/N with conductance UA/N, so every cell has the same effectiveness
// eps = 1 - exp(-UA / (mdot_air cp)). Fan speeds are fractions of the rated air flow, floored at
// 1 % (natural convection through a stopped fan is neglected).
struct AirSide {
  double capacity_rate;  // W/K per cell: mdot_air cp / N
  double ntu;            // UA / (mdot_air cp) before fouling
};

inline AirSide air_side(const CoilParams& coil, double fan, double exponent, std::size_t cells) {
  const double fraction = std::max(fan, 0.01);
  const double c = coil.air_flow * fraction * kAirCp;
  return {c / static_cast<double>(cells), coil.ua_air * std::pow(fraction, exponent) / c};
}

// Heat from the air stream into one cell's wall [W]: capacity_rate * eps * (T_air_in - T_wall),
// with the NTU scaled by the fouling factor (1 = clean).
template <class S>
S air_to_wall(const AirSide& air, const S& fouling, const S& t_air_in, const S& t_wall) {
  using std::exp;
  const S eps = 1.0 - exp(-air.ntu * fouling);
  return air.capacity_rate * eps * (t_air_in - t_wall);
}

}  // namespace hvac_twin::plant::hp
