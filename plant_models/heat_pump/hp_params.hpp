// Parameters of the R32 split heat pump in cooling mode (outdoor coil = condenser, indoor coil
// = evaporator) and of the zone it serves, in SI units. Defaults describe a small split unit of
// about 3.5 kW rated cooling; plant_models/README.md says where each value comes from.
#pragma once

#include <array>
#include <vector>

#include "plant_models/core/model_info.hpp"
#include "plant_models/heat_pump/hp_layout.hpp"
#include "plant_models/zone/zone_rc.hpp"

namespace hvac_twin::plant::hp {

struct CoilParams {
  double volume;         // m3, refrigerant side
  double inner_area;     // m2, refrigerant-side heat transfer area
  double wall_capacity;  // J/K, tubes and fins
  double ua_air;         // W/K, air side at rated air flow
  double air_flow;       // kg/s, rated
  double dp_nominal;     // Pa, refrigerant pressure drop at the nominal mass flow
  double htc_two_phase;  // W/(m2 K), condensing or boiling
};

struct Params {
  // Structure.
  int cells = 12;  // finite-volume cells per heat exchanger
  bool augment_gains = true;
  bool augment_leak = true;
  bool end_walls = true;  // a state for the wall at each sensed coil end (hp_layout.hpp, End)
  std::array<bool, kNumFactors> augment{};  // factors carried as states (Factor, hp_layout.hpp)

  // Compressor (variable-speed rotary).
  double displacement = 13.0e-6;    // m3 per revolution
  double speed_rated = 50.0;        // Hz
  double eta_v0 = 0.95;             // volumetric efficiency at pressure ratio 1
  double eta_v_slope = 0.025;       // its loss per unit of pressure ratio above 1
  double eta_is_peak = 0.70;        // isentropic efficiency at the best pressure ratio and speed
  double pi_optimum = 2.8;          // pressure ratio of the peak
  double eta_is_pi_curv = 0.015;    // loss per (pressure ratio - optimum)^2
  double eta_is_speed_curv = 0.10;  // loss per ((speed - rated)/rated)^2
  double kappa = 1.19;              // polytropic exponent of the isentropic work
  double motor_efficiency = 0.90;   // electric -> shaft

  // Electronic expansion valve: mdot = C a sqrt(2 rho_in dp).
  double valve_coefficient = 7.0e-7;  // m2, discharge coefficient times full-open area

  CoilParams cond{1.2e-3, 0.70, 4500.0, 750.0, 0.65, 40e3, 3000.0};
  CoilParams evap{0.5e-3, 0.39, 2000.0, 450.0, 0.25, 30e3, 4000.0};
  double htc_liquid = 1500.0;         // W/(m2 K)
  double htc_vapour = 800.0;          // W/(m2 K)
  double htc_blend = 10e3;            // J/kg, single-phase alpha blends to two-phase near a line
  double dryout_quality = 0.8;        // 1, boiling dryout onset (two_phase_htc 1, 2)
  double nominal_mass_flow = 0.0143;  // kg/s, reference of the pressure drops
  double discharge_line_volume = 2.5e-5;  // m3
  double liquid_line_volume = 9.0e-5;     // m3
  double suction_line_volume = 2.5e-4;    // m3
  double fan_ua_exponent = 0.6;           // UA_air ~ (air flow)^exponent
  double smoothing_width = 300.0;         // J/kg, density smoothing at the saturation lines (lines)

  // Closures (integer-coded; see hp_profile.hpp). The defaults are the filter's model; the
  // benchmark truth changes them to closures the filter does not share.
  int void_fraction = 1;     // 0 homogeneous, 1 Zivi, 2 Smith (quadrature)
  int two_phase_htc = 1;     // 0 constant, 1 quality-dependent correlations, 2 their variant
  double dp_exponent = 2.0;  // friction drop ~ (mdot / nominal)^exponent
  int dp_distribution = 0;   // 0 uniform along the coil, 1 by the cells' specific volume

  double nameplate_charge = 0.50;  // kg, factory charge incl. a 5 m line set

  // Values of the unknowns when they are not estimated (not augmented).
  double internal_gains = 300.0;  // W
  double leak_rate = 0.0;         // g/h
  // The factors' values (their states' initial values when augmented): all 1 but the
  // void-fraction exponent (Zivi's 2/3) and the sensor offsets (0 K).
  std::array<double, kNumFactors> factor{1.0, 1.0, 1.0, 2.0 / 3.0, 1.0, 1.0, 1.0,
                                         1.0, 1.0, 0.0, 0.0,       0.0, 0.0};

  ZoneRc::Params zone{};  // hp_fraction_air is 1: the indoor unit blows into the air node
};

// What a factor is as a parameter and as a state: its name (of both), range, the filter's
// initial sigma and random walk [1/sqrt(s)], whether a filter considers it rather than
// estimates it by default, and a description.
struct FactorInfo {
  const char* name;
  const char* unit;
  double min, max;
  double initial_std;
  double process_noise;
  bool consider;
  bool calibrate;  // estimated while commissioning with the charge known (StateInfo::calibrate)
  const char* description;
};
const std::array<FactorInfo, kNumFactors>& factor_info();

// The parameter table (names, units, defaults, bounds, descriptions) and the map it reads.
std::vector<ParameterInfo> parameter_info();
Params params_from_map(const ParameterMap& values);

}  // namespace hvac_twin::plant::hp
