// State, input and output layout of the R32 heat pump, declared once. The number of cells per
// heat exchanger and the augmented unknowns are structural parameters, so the layout is computed
// at construction; everything else indexes through these named slices.
//
// State, in this order (units in brackets; enthalpies in kJ/kg keep the covariance well scaled):
//   charge            [kg]     total refrigerant mass (changes only by a leak)
//   M_cond            [kg]     mass in the high side: discharge line, condenser, liquid line
//   h_discharge_line  [kJ/kg]  discharge line (adiabatic cell): the condenser inlet
//   h_cond_i          [kJ/kg]  condenser cell outlet enthalpies, i = 0..N-1 in flow direction
//   h_liquid_line     [kJ/kg]  liquid line (adiabatic cell): the expansion-valve inlet
//   h_evap_i          [kJ/kg]  evaporator cell outlet enthalpies
//   h_suction_line    [kJ/kg]  suction line (adiabatic cell): the compressor inlet
//   T_air             [degC]   zone air (as zone_rc): the evaporator's air inlet
//   factors           [1]      uncertain parameters the pressure solve reads (augmented,
//                              optional; Factor below): fouling, evap_ua_factor,
//                              comp_flow_factor, void_exponent, cond_htc_factor,
//                              evap_htc_factor, friction_factor
//   Tw_cond_i         [degC]   condenser wall (tube and fin) temperatures
//   Tw_evap_i         [degC]   evaporator wall temperatures
//   Tw_end_j          [degC]   the wall at each sensed coil end (End below; optional,
//                              end_walls): its own heat balance and lag
//   T_mass            [degC]   building mass (as zone_rc)
//   Q_int             [W]      internal gains            (augmented, optional)
//   leak_rate         [g/h]    refrigerant leak           (augmented, optional)
//   factors           [1, K]   the others: valve_factor, comp_efficiency_factor, and the wall
//                              sensors' offsets [K] (cond_in_wall_offset ... evap_out_wall_offset)
// The low-side mass is charge - M_cond; the two pressures are algebraic (see heat_pump.hpp).
// The states up to the first group of factors are everything the pressure solve reads: the
// cells' masses depend on the enthalpies and, through the cell profiles' position weights, on
// the air temperatures and the conductances.
#pragma once

#include <array>
#include <cstddef>

namespace hvac_twin::plant::hp {

struct Slice {
  std::size_t begin = 0;
  std::size_t size = 0;
  [[nodiscard]] std::size_t operator[](std::size_t i) const { return begin + i; }
  [[nodiscard]] std::size_t last() const { return begin + size - 1; }
};

inline constexpr std::size_t kNone = static_cast<std::size_t>(-1);

// Uncertain parameters of the model that a filter can carry as states (random walks it
// estimates, or "consider" states whose uncertainty it carries without estimating them), each a
// factor on a nominal value except the void-fraction exponent and the wall sensors' offsets
// (added to the wall temperature a sensor reads, in K). Parameters and state names:
// hp_params.cpp (factor_table).
enum Factor : std::size_t {
  kCondUa,         // fouling: outdoor-coil air-side UA (fouling, air flow)
  kEvapUa,         // evap_ua_factor: indoor-coil air-side UA
  kCompFlow,       // comp_flow_factor: compressor volumetric efficiency
  kVoidExponent,   // void_exponent: slip-ratio void fraction (rho_v/rho_l)^e, Zivi 2/3
  kCondHtc,        // cond_htc_factor: condensing heat transfer coefficient
  kEvapHtc,        // evap_htc_factor: boiling heat transfer coefficient
  kFriction,       // friction_factor: both coils' refrigerant pressure drops
  kValve,          // valve_factor: expansion-valve flow coefficient
  kCompWork,       // comp_efficiency_factor: compressor isentropic efficiency
  kCondInOffset,   // cond_in_wall_offset: the condenser-inlet wall sensor's offset [K]
  kCondOutOffset,  // cond_out_wall_offset
  kEvapInOffset,   // evap_in_wall_offset
  kEvapOutOffset,  // evap_out_wall_offset
  kNumFactors
};
// Factors before this one feed the pressure solve.
inline constexpr std::size_t kFirstLateFactor = kValve;

// The four coil ends a wall sensor sits at, in the order of their end-wall states.
enum End : std::size_t { kEndCondIn, kEndCondOut, kEndEvapIn, kEndEvapOut, kNumEnds };

struct Layout {
  std::size_t cells = 0;
  std::size_t charge = 0, m_cond = 1;
  Slice h_cond, tw_cond, h_evap, tw_evap;
  Slice tw_end;  // size 0 unless the end walls are states
  std::size_t h_dl = 0, h_ll = 0, h_sl = 0, t_air = 0, t_mass = 0;
  std::size_t refrigerant_states = 0;  // states [0, refrigerant_states) feed the pressure solve
  std::size_t q_int = kNone, leak = kNone;        // kNone: not augmented
  std::array<std::size_t, kNumFactors> factor{};  // kNone: not augmented
  std::size_t fouling = kNone;                    // factor[kCondUa], by its historical name
  std::size_t size = 0;

  Layout(std::size_t n, bool gains, bool leak_rate, bool end_walls,
         const std::array<bool, kNumFactors>& augmented)
      : cells(n) {
    factor.fill(kNone);
    std::size_t at = 2;
    auto take = [&at](std::size_t count) {
      const Slice s{at, count};
      at += count;
      return s;
    };
    // What the pressure solve reads first (masses, enthalpies, air temperature, fouling), so
    // derivative chunks past it skip the solve (see HeatPumpR32::evaluate).
    h_dl = at++;
    h_cond = take(n);
    h_ll = at++;
    h_evap = take(n);
    h_sl = at++;
    t_air = at++;
    for (std::size_t f = 0; f < kFirstLateFactor; ++f)
      if (augmented[f]) factor[f] = at++;
    refrigerant_states = at;
    tw_cond = take(n);
    tw_evap = take(n);
    if (end_walls) tw_end = take(kNumEnds);
    t_mass = at++;
    if (gains) q_int = at++;
    if (leak_rate) leak = at++;
    for (std::size_t f = kFirstLateFactor; f < kNumFactors; ++f)
      if (augmented[f]) factor[f] = at++;
    fouling = factor[kCondUa];
    size = at;
  }

  // The wall state of the cell at a sensed end.
  [[nodiscard]] std::size_t end_cell_wall(End end) const {
    switch (end) {
      case kEndCondIn:
        return tw_cond[0];
      case kEndCondOut:
        return tw_cond.last();
      case kEndEvapIn:
        return tw_evap[0];
      default:
        return tw_evap.last();
    }
  }
};

// Inputs, all read from the unit's points.
enum Input : std::size_t {
  kCompressorSpeed,     // Hz
  kValveOpening,        // 1, 0..1 of the expansion valve's full stroke
  kIndoorFan,           // 1, fraction of the rated indoor air flow
  kOutdoorFan,          // 1, fraction of the rated outdoor air flow
  kOutdoorTemperature,  // degC
  kNumInputs
};
// Below this compressor speed the unit stands still [Hz] (as the leak detector's default).
inline constexpr double kStoppedBelowHz = 5.0;

// Outputs: measurable points first, then virtual sensors.
enum Output : std::size_t {
  kSuctionPressure,          // Pa, evaporator outlet = compressor inlet
  kDischargePressure,        // Pa, compressor outlet = condenser inlet
  kCondWallTempIn,           // degC
  kCondWallTempOut,          // degC
  kEvapWallTempIn,           // degC
  kEvapWallTempOut,          // degC
  kZoneAirTemperature,       // degC
  kSupplyAirTemperature,     // degC, indoor coil outlet air
  kCompressorPower,          // W, electric
  kCondenserOutletPressure,  // Pa
  kValveInletEnthalpy,       // kJ/kg
  kCondenserHeatFlow,        // W, refrigerant to condenser wall
  kEvaporatorHeatFlow,       // W, evaporator wall to refrigerant
  kCoolingCapacity,          // W, heat taken from the indoor air
  kRefrigerantMassFlow,      // kg/s, through the compressor
  kDischargeTemperature,     // degC
  kSuperheat,                // K, at the compressor inlet
  kSubcooling,               // K, at the expansion-valve inlet
  kCop,                      // 1, cooling capacity / electric power
  kCharge,                   // kg
  kLeakRate,                 // g/h
  kMassTemperature,          // degC
  kInternalGains,            // W
  kOutdoorCoilFouling,       // 1
  kNumOutputs
};

}  // namespace hvac_twin::plant::hp
