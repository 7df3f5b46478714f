// Coefficients of the R32 equation of state and of its ancillary equations, copied verbatim
// from data/r32_eos.json (Tillner-Roth & Yokozeki 1997; ancillaries from the CoolProp fluid
// file, see the "_source" note there). A unit test compares every number here with the JSON.
// Internal to the refrigerant library.
#pragma once

#include <array>

namespace hvac_twin::plant::r32::coeff {

// alpha0 = ln(delta) + a1 + a2 tau + a3 ln(tau) + sum m_k ln(1 - exp(-theta_k tau))
inline constexpr double kA1 = -8.258096;
inline constexpr double kA2 = 6.353098;
inline constexpr double kA3 = 3.004486;
inline constexpr std::array<double, 4> kM = {1.160761, 2.645151, 5.794987, 1.129475};
inline constexpr std::array<double, 4> kTheta = {2.2718538, 11.914421, 5.1415638, 32.768217};

// alphar = sum n_i delta^d_i tau^t_i exp(-delta^l_i)   (no exp factor when l_i = 0)
inline constexpr std::array<double, 19> kN = {
    1.046634,   -0.5451165,  -0.002448595, -0.04877002,  0.03520158,   0.00162275,  2.377225e-05,
    0.029149,   0.003386203, -0.004202444, 0.0004782025, -0.005504323, -0.02418396, 0.4209034,
    -0.4616537, -1.200513,   -2.59155,     -1.400145,    0.8263017};
inline constexpr std::array<int, 19> kD = {1, 2, 5, 1, 1, 3, 8, 4, 4, 4, 8, 3, 5, 1, 1, 3, 1, 2, 3};
inline constexpr std::array<double, 19> kT = {0.25, 1.0,  -0.25, -1.0, 2.0,  2.0,  0.75,
                                              0.25, 18.0, 26.0,  -1.0, 25.0, 1.75, 4.0,
                                              5.0,  1.0,  1.5,   1.0,  0.5};
inline constexpr std::array<int, 19> kL = {0, 0, 0, 0, 0, 0, 0, 0, 4, 3, 1, 4, 1, 2, 2, 1, 1, 1, 1};

// Ancillaries (starting values only), theta = 1 - T/Tc:
// p_sat = pc exp(Tc/T sum n theta^t); rho_l = rhoc (1 + sum n theta^t);
// rho_v = rhoc exp(Tc/T sum n theta^t)   [rhoc molar in the JSON; mass-based here]
inline constexpr std::array<double, 6> kPsN = {0.019194334673139708, -6.794802163795212,
                                               9.276391392786632,    -12.327153852761946,
                                               28.46579606476374,    -28.570870718190093};
inline constexpr std::array<double, 6> kPsT = {0.531, 0.979, 2.203, 2.382, 3.421, 3.558};
inline constexpr std::array<double, 6> kRhoLN = {3.0283368557227064, -13.30754793568124,
                                                 53.97035773548243,  -41.10515088784585,
                                                 0.6410010855629815, -18.757652443918627};
inline constexpr std::array<double, 6> kRhoLT = {0.358, 0.676, 0.831, 0.88, 2.592, 16.556};
inline constexpr std::array<double, 6> kRhoVN = {-0.06522522852577171, -3.3577643698607456,
                                                 -2.746299718061842,   -64.77289013657663,
                                                 511.3349286855849,    -1525.315265366156};
inline constexpr std::array<double, 6> kRhoVT = {0.069, 0.425, 1.18, 8.115, 12.06, 16.085};

}  // namespace hvac_twin::plant::r32::coeff
