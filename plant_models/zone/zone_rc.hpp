// Lumped thermal RC model of one zone: air and building-mass temperatures, heated (or cooled) by
// the heat pump, with unmeasured internal gains appended to the state as a random walk.
//
//   C_air  dT_air/dt  = UA_am (T_mass - T_air) + UA_ao (T_out - T_air) + f_hp Q_hp + f_g Q_int
//   C_mass dT_mass/dt = UA_am (T_air - T_mass) + UA_mo (T_out - T_mass)
//                       + (1 - f_hp) Q_hp + (1 - f_g) Q_int
//   dQ_int/dt         = 0                        (augmented random walk: the filter adds noise)
//
// T in degC, Q in W, C in J/K, UA in W/K; f_hp, f_g are the shares delivered to the air node (the
// rest is radiant, to the mass node). The heat pump's delivered heat Q_hp (negative when cooling)
// and the outdoor temperature T_out are inputs. Energy balance (checked by a test):
//   d/dt (C_air T_air + C_mass T_mass) = Q_hp + Q_int - UA_ao (T_air - T_out)
//                                        - UA_mo (T_mass - T_out)
// Outputs: the zone air temperature a sensor reads, and virtual sensors for the mass
// temperature, the internal gains and the envelope heat loss (the last sum above).
#pragma once

#include <array>
#include <span>

#include "plant_models/core/model.hpp"
#include "plant_models/core/model_info.hpp"

namespace hvac_twin::plant {

class ZoneRc {
 public:
  // State, input and output layout, declared once. Nothing else indexes with bare integers.
  enum State : std::size_t { kTAir, kTMass, kQInt, kNumStates };
  enum Input : std::size_t { kQHp, kTOut, kNumInputs };
  enum Output : std::size_t {
    kZoneAirTemperature,
    kMassTemperature,
    kInternalGains,
    kEnvelopeHeatLoss,
    kNumOutputs
  };

  struct Params {
    double c_air = 2.0e6;            // J/K   air, furniture, light partitions
    double c_mass = 3.0e7;           // J/K   slab and walls
    double ua_air_mass = 600.0;      // W/K   air <-> mass surface coupling
    double ua_air_out = 120.0;       // W/K   windows and ventilation
    double ua_mass_out = 60.0;       // W/K   opaque envelope
    double hp_fraction_air = 1.0;    // 1     share of heat-pump heat to the air node
    double gain_fraction_air = 0.6;  // 1     share of internal gains to the air node
  };

  static constexpr const char* kType = "zone_rc";

  explicit ZoneRc(const Params& p) : p_(p) {}
  explicit ZoneRc(const ParameterMap& values);  // values: every parameter, validated upstream

  [[nodiscard]] static std::vector<ParameterInfo> parameter_info();
  [[nodiscard]] static ModelLayout make_layout();
  [[nodiscard]] ModelLayout layout() const { return make_layout(); }
  [[nodiscard]] const Params& params() const { return p_; }

  // The zone's energy balance, shared with models that contain the zone (the heat pump passes
  // a heat flow that depends on its own state, hence the separate scalar type Q).
  template <class S, class Q>
  static void balance(const Params& p, const S& t_air, const S& t_mass, const S& q_int,
                      const Q& q_hp, double t_out, S& dt_air, S& dt_mass) {
    const S q_am = p.ua_air_mass * (t_mass - t_air);  // W, mass -> air
    dt_air = (q_am + p.ua_air_out * (t_out - t_air) + p.hp_fraction_air * q_hp +
              p.gain_fraction_air * q_int) /
             p.c_air;
    dt_mass = (-q_am + p.ua_mass_out * (t_out - t_mass) + (1.0 - p.hp_fraction_air) * q_hp +
               (1.0 - p.gain_fraction_air) * q_int) /
              p.c_mass;
  }

  template <class S>
  int rhs(std::span<const S> x, std::span<const double> u, std::span<S> xdot) const {
    balance(p_, x[kTAir], x[kTMass], x[kQInt], u[kQHp], u[kTOut], xdot[kTAir], xdot[kTMass]);
    xdot[kQInt] = S(0.0);
    return kModelOk;
  }

  template <class S>
  int outputs(std::span<const S> x, std::span<const double> u, std::span<S> y) const {
    const double t_out = u[kTOut];
    y[kZoneAirTemperature] = x[kTAir];
    y[kMassTemperature] = x[kTMass];
    y[kInternalGains] = x[kQInt];
    y[kEnvelopeHeatLoss] =
        p_.ua_air_out * (x[kTAir] - t_out) + p_.ua_mass_out * (x[kTMass] - t_out);
    return kModelOk;
  }

 private:
  Params p_;
};

}  // namespace hvac_twin::plant
