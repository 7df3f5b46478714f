#include "plant_models/zone/zone_rc.hpp"

#include <cstddef>
#include <string>

namespace hvac_twin::plant {
namespace {

// The parameter table, declared once: name, unit, default, bounds, description, and the member
// it sets. Defaults are a 100 m2 well-insulated room with a concrete slab; see
// plant_models/README.md for how they were chosen.
struct ParamEntry {
  ParameterInfo info;
  double ZoneRc::Params::*member;
};

const std::vector<ParamEntry>& param_table() {
  using P = ZoneRc::Params;
  const P d{};
  static const std::vector<ParamEntry> table{
      {{"C_air", "J/K", d.c_air, 1e4, 1e9, false,
        "heat capacity of the air node: air, furniture and light partitions"},
       &P::c_air},
      {{"C_mass", "J/K", d.c_mass, 1e5, 1e10, false,
        "heat capacity of the building-mass node: slab and heavy walls"},
       &P::c_mass},
      {{"UA_air_mass", "W/K", d.ua_air_mass, 1.0, 1e5, false,
        "conductance between the air and the mass surfaces"},
       &P::ua_air_mass},
      {{"UA_air_out", "W/K", d.ua_air_out, 0.0, 1e5, false,
        "conductance from the air to outdoors: windows and ventilation"},
       &P::ua_air_out},
      {{"UA_mass_out", "W/K", d.ua_mass_out, 0.0, 1e5, false,
        "conductance from the mass to outdoors: the opaque envelope"},
       &P::ua_mass_out},
      {{"hp_fraction_air", "1", d.hp_fraction_air, 0.0, 1.0, false,
        "share of the heat pump's delivered heat that goes to the air node"},
       &P::hp_fraction_air},
      {{"gain_fraction_air", "1", d.gain_fraction_air, 0.0, 1.0, false,
        "share of the internal gains that goes to the air node (the rest is radiant)"},
       &P::gain_fraction_air},
  };
  return table;
}

}  // namespace

ZoneRc::ZoneRc(const ParameterMap& values) {
  for (const auto& e : param_table()) {
    const auto it = values.find(e.info.name);
    p_.*e.member = it == values.end() ? e.info.default_value : it->second;
  }
}

std::vector<ParameterInfo> ZoneRc::parameter_info() {
  std::vector<ParameterInfo> out;
  for (const auto& e : param_table())
    out.push_back(e.info);
  return out;
}

ModelLayout ZoneRc::make_layout() {
  ModelLayout l;
  l.states.resize(kNumStates);
  //            name      unit    min     max    init  std   q [unit/sqrt(s)]  abs_tol
  l.states[kTAir] = {"T_air", "degC", -40.0, 70.0,  20.0,
                     2.0,     1e-3,   1e-6,  false, "zone air temperature"};
  // The mass node also takes heat nobody models (solar on the slab, the ground): its random walk
  // (0.03 K per sqrt(h)) keeps the filter from growing overconfident about it. With 1e-4 the
  // integration test saw the mass error reach 3.6 sigma after internal-gain steps; with 5e-4,
  // 2.3 sigma, the gains estimate unchanged.
  l.states[kTMass] = {"T_mass", "degC", -40.0, 70.0,  20.0,
                      3.0,      5e-4,   1e-6,  false, "building-mass temperature"};
  l.states[kQInt] = {"Q_int", "W",
                     -2000.0, 20000.0,
                     300.0,   300.0,
                     1.0,     1e-3,
                     true,    "internal heat gains: people, equipment, solar (random walk)"};
  l.inputs.resize(kNumInputs);
  l.inputs[kQHp] = {
      "heat_pump_heat", "W",
      -30000.0,         30000.0,
      kRequired,        "heat delivered to the zone by the heat pump (negative when cooling)"};
  l.inputs[kTOut] = {"outdoor_temperature",    "degC", -50.0, 60.0, kRequired,
                     "outdoor air temperature"};
  l.outputs.resize(kNumOutputs);
  l.outputs[kZoneAirTemperature] = {"zone_air_temperature", "degC", -40.0, 70.0, kRequired,
                                    "zone air temperature"};
  l.outputs[kMassTemperature] = {
      "mass_temperature", "degC", -40.0, 70.0, kRequired, "building-mass temperature (unmeasured)"};
  l.outputs[kInternalGains] = {"internal_gains", "W",       -2000.0,
                               20000.0,          kRequired, "internal heat gains (unmeasured)"};
  l.outputs[kEnvelopeHeatLoss] = {"envelope_heat_loss",
                                  "W",
                                  -1e6,
                                  1e6,
                                  kRequired,
                                  "heat flow from the zone to outdoors through the envelope"};
  return l;
}

}  // namespace hvac_twin::plant
