// R32 (difluoromethane) reference equation of state: the Helmholtz-energy equation of
// Tillner-Roth & Yokozeki, J. Phys. Chem. Ref. Data 26(6), 1273 (1997), implemented from its
// formulas (coefficients in data/r32_eos.json, copied verbatim into r32_eos.cpp).
//
// Units: SI and MASS-based throughout: T [K], p [Pa], rho [kg/m^3], h, u, g [J/kg],
// s, cp, cv [J/(kg K)], w [m/s]. Reference state IIR (h = 200 kJ/kg, s = 1 kJ/(kg K) for
// saturated liquid at 273.15 K).
//
// This is the accurate, slow path (tens of microseconds per flash); the model calls the fast
// (p, h) tables in r32_table.hpp, which are built from these functions.
//
// Errors: no exceptions, no allocation, no I/O. Every solver returns a Status; anything other
// than kOk leaves finite (but meaningless) numbers in the result. Status values follow the
// SUNDIALS callback convention (0 ok, > 0 recoverable).
// Thread-safety: all functions are pure (no shared state) and may be called from any thread.
#pragma once

#include "plant_models/refrigerant/status.hpp"

namespace hvac_twin::plant::r32 {

// --- Constants of the equation (mass-based where it matters) -------------------------------
inline constexpr double kMolarMass = 0.052024;                // kg/mol
inline constexpr double kGasConstantMolar = 8.314471;         // J/(mol K)
inline constexpr double kR = kGasConstantMolar / kMolarMass;  // J/(kg K), specific
inline constexpr double kTc = 351.255;                        // K, critical = reducing T
inline constexpr double kPc = 5.782e6;                        // Pa
inline constexpr double kRhoc = 8150.0846 * kMolarMass;       // kg/m^3, reducing density
inline constexpr double kTtriple = 136.34;                    // K
inline constexpr double kTmaxEos = 435.0;                     // K, upper validity of the EOS
inline constexpr double kPmaxEos = 70.0e6;                    // Pa, upper validity of the EOS

// Reduced Helmholtz energy alpha = a/(R T) = alpha0 + alphar at delta = rho/rhoc,
// tau = Tc/T, with its derivatives stored pre-multiplied (delta * d/ddelta, tau * d/dtau), the
// combinations the property relations need.
struct Helmholtz {
  double a0 = 0.0;        // alpha0
  double t_a0_t = 0.0;    // tau * dalpha0/dtau
  double tt_a0_tt = 0.0;  // tau^2 * d2alpha0/dtau2
  double ar = 0.0;        // alphar
  double d_ar_d = 0.0;    // delta * dalphar/ddelta
  double dd_ar_dd = 0.0;  // delta^2 * d2alphar/ddelta2
  double t_ar_t = 0.0;    // tau * dalphar/dtau
  double tt_ar_tt = 0.0;  // tau^2 * d2alphar/dtau2
  double dt_ar_dt = 0.0;  // delta * tau * d2alphar/(ddelta dtau)
};

// alpha0, alphar and derivatives; delta > 0, tau > 0.
Helmholtz helmholtz(double delta, double tau);

// Thermodynamic state from temperature and density (any phase, including metastable states:
// this is the single-phase surface of the EOS, no phase check).
struct Properties {
  double T = 0.0;          // K
  double rho = 0.0;        // kg/m^3
  double p = 0.0;          // Pa
  double h = 0.0;          // J/kg
  double s = 0.0;          // J/(kg K)
  double u = 0.0;          // J/kg
  double g = 0.0;          // J/kg (Gibbs)
  double cv = 0.0;         // J/(kg K)
  double cp = 0.0;         // J/(kg K)
  double w = 0.0;          // m/s (speed of sound; 0 where w^2 < 0, i.e. inside the spinodal)
  double dp_dT_rho = 0.0;  // Pa/K
  double dp_drho_T = 0.0;  // Pa m^3/kg
  double dh_dT_rho = 0.0;  // J/(kg K)
  double dh_drho_T = 0.0;  // J m^3/kg^2
};
Properties properties_trho(double T, double rho);
double pressure_trho(double T, double rho);  // p only [Pa]

// Partial derivatives of (T, rho) with respect to (p, h), from the single-phase surface at a
// state (the inverse of the (p, h) <- (T, rho) Jacobian).
struct PhDerivatives {
  double dT_dp_h = 0.0;    // K/Pa
  double dT_dh_p = 0.0;    // K kg/J
  double drho_dp_h = 0.0;  // kg/(m^3 Pa)
  double drho_dh_p = 0.0;  // kg^2/(m^3 J)
};
PhDerivatives ph_derivatives(const Properties& s);

// --- Saturation (phase equilibrium: equal T, p and Gibbs energy) -----------------------------
struct Saturation {
  Status status = Status::kNotConverged;
  double T = 0.0;  // K
  double p = 0.0;  // Pa
  Properties liquid;
  Properties vapour;
  // Derivatives ALONG the saturation curve with respect to p (Clapeyron + single phase):
  double dT_dp = 0.0;      // K/Pa
  double dh_l_dp = 0.0;    // J/(kg Pa)
  double dh_v_dp = 0.0;    // J/(kg Pa)
  double drho_l_dp = 0.0;  // kg/(m^3 Pa)
  double drho_v_dp = 0.0;  // kg/(m^3 Pa)
};
// Valid for kTtriple - 1 K <= T < kTc (converges to within 1 mK of Tc); else kOutOfRange.
Saturation saturation_t(double T);
// Valid for p_triple (~48 Pa) <= p < kPc; else kOutOfRange.
Saturation saturation_p(double p);

// --- Single-phase density from (p, T) --------------------------------------------------------
enum class Phase : int { kLiquid = 0, kVapour = 1, kTwoPhase = 2, kSupercritical = 3 };

struct DensityResult {
  Status status = Status::kNotConverged;
  Phase phase = Phase::kLiquid;  // kSupercritical for p >= pc; kVapour for T >= Tc, p < pc
  double rho = 0.0;              // kg/m^3
};
// Density of the thermodynamically stable phase (a saturation solve decides when T < Tc and
// p < pc; exactly at p_sat it returns the liquid). p in (0, kPmaxEos], T in [kTtriple - 1 K,
// 1.2 kTmaxEos]; else kOutOfRange.
DensityResult density_pt(double p, double T);

// --- Flash from (p, h) ----------------------------------------------------------------------
struct FlashResult {
  Status status = Status::kNotConverged;
  Phase phase = Phase::kLiquid;
  double T = 0.0;    // K
  double rho = 0.0;  // kg/m^3
  // Thermodynamic quality (h - h_l(p)) / (h_v(p) - h_l(p)) for p < pc: the vapour mass fraction
  // in two phase, < 0 for subcooled liquid, > 1 for superheated vapour. For p >= pc: -1 if
  // T < Tc, 2 otherwise (no saturation exists).
  double quality = 0.0;
};
FlashResult flash_ph(double p, double h);

// Single-phase (p, h) flash on a given branch from a starting guess, without a saturation solve:
// solves p(T, rho) = p, h(T, rho) = h with T in [T_lo, T_hi] and rho in [rho_lo, rho_hi], a
// branch of the EOS on which p rises with rho and p(T, rho_lo) <= p <= p(T, rho_hi) for every T
// of the bracket. liquid_like raises rho_lo to just below the saturated-liquid density of the
// current T (required for liquid states far below the saturation temperature of p). Used by
// flash_ph and by the table builder.
struct Bracket {
  double T_lo, T_hi, rho_lo, rho_hi;
  bool liquid_like;
};
FlashResult flash_ph_branch(double p, double h, const Bracket& b, double T_guess, double rho_guess);

}  // namespace hvac_twin::plant::r32
