// Steady states of the R32 heat pump for the convergence study (tests and benchmark):
//  - the model's own steady state at a given cell count, the zone held at its temperature;
//  - the continuous reference: the same physics with no cells at all. Each coil's steady
//    profile, dh/ds = U(h) (T_air - T(h)) / mdot with U the refrigerant film and the air side in
//    series (the wall in local balance), is integrated along the tube by RK4 in 4000 steps, its
//    mass by Simpson's rule; the discharge pressure, suction pressure and suction enthalpy are
//    found by Newton's method so that the valve passes the compressor's flow, the evaporator's
//    outlet is the compressor's inlet and the circuit holds the charge. It shares with the model
//    only the closures (property table, compressor, valve, air side, the local heat-transfer
//    coefficient and void fraction of hp_profile.hpp), not the discretisation.
// Test support: allocates freely, throws std::runtime_error when a steady state is not found.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "plant_models/core/model_info.hpp"

namespace hvac_twin::test {

struct OperatingPoint {
  const char* name;
  double speed;   // Hz
  double valve;   // 1
  double t_out;   // degC
  double t_zone;  // degC, held
};

// Part load in mild weather, the nominal point, full load in hot weather; valve openings for
// about 5-6 K of superheat.
inline constexpr std::array<OperatingPoint, 3> kConvergencePoints{{
    {"25 Hz, 27/24 degC", 25.0, 0.296, 27.0, 24.0},
    {"50 Hz, 35/27 degC", 50.0, 0.374, 35.0, 27.0},
    {"85 Hz, 40/27 degC", 85.0, 0.435, 40.0, 27.0},
}};

struct SteadyAnswer {
  double subcooling = 0, superheat = 0;    // K
  double p_discharge = 0, p_suction = 0;   // Pa
  double tw_cond_in = 0, tw_cond_out = 0;  // degC
  double tw_evap_in = 0, tw_evap_out = 0;  // degC
  double q_cond = 0, q_evap = 0;           // W
};

// The model (heat_pump_r32 with `params`, cells overridden) at steady state with `charge` [kg].
SteadyAnswer model_steady(const plant::ParameterMap& params, int cells, const OperatingPoint& op,
                          double charge);

// The model's response to a scripted transient from its steady state at the operating point
// (`charge` [kg], the zone held): the valve swung +-5 % of its opening in a 50 s square wave for
// 10 minutes (a superheat controller hunting, as the flooded 20 Hz point of estimation_bench
// does), then the compressor 8 Hz faster for 10 minutes. The six points a unit measures, every
// second from t = 1 s: suction and discharge pressure [Pa], then the condenser-inlet,
// condenser-outlet, evaporator-inlet and evaporator-outlet wall temperatures [degC]; index 0 is
// the steady state.
inline constexpr int kTransientSeconds = 1200;
using MeasuredPoints = std::array<double, 6>;
std::vector<MeasuredPoints> model_transient(const plant::ParameterMap& params, int cells,
                                            const OperatingPoint& op, double charge);

// The error in point `j`'s motion (its change from its steady value at index 0) of `run` against
// `ref`, over the transient: RMS and largest magnitude, in the point's unit.
struct MotionError {
  double rms = 0, largest = 0;
};
MotionError motion_error(const std::vector<MeasuredPoints>& run,
                         const std::vector<MeasuredPoints>& ref, std::size_t j);

// The charge [kg] at which the model reproduces `subcooling` [K] at the operating point (secant
// iteration from the nameplate, to 1e-4 K).
double model_charge_for_subcooling(const plant::ParameterMap& params, int cells,
                                   const OperatingPoint& op, double subcooling);

// The continuous reference with the model's parameters (uniform friction distribution only).
SteadyAnswer continuous_steady(const plant::ParameterMap& params, const OperatingPoint& op,
                               double charge, int steps = 4000);

}  // namespace hvac_twin::test
