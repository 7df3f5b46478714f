// The ends of one coil cell from the R32 property table: the states where its profile's vapour
// and liquid pieces end (hp_profile.hpp, CellEnds), with the slopes of those states' enthalpy in
// the cell pressure and in the end's enthalpy (the model's mass partials need them).
// Templated on the scalar (double or Dual<K>); no allocation, no exceptions; thread-safe.
#pragma once

#include "plant_models/heat_pump/hp_profile.hpp"
#include "plant_models/refrigerant/r32_table.hpp"

namespace hvac_twin::plant::hp {

// The state at which a single-phase piece ends for a cell end of enthalpy h [J/kg]: its own
// state, the saturation line, or the branch just beyond the line at V(h) or L(h); e is that
// state's enthalpy, de_dp and de_dh its slopes in the cell pressure and in h.
template <class T>
struct AnchorState {
  r32::PhState<T> state;
  T de_dp{0.0}, de_dh{1.0};
};

template <class T>
AnchorState<T> anchor_state(const T& p, const T& h, const r32::PhState<T>& own,
                            const r32::SatState<T>& s, bool vapour, double w) {
  const Anchor kind = vapour ? vapour_anchor(h, s.h_v, w) : liquid_anchor(h, s.h_l, w);
  AnchorState<T> a{own, T(0.0), T(1.0)};
  if (kind == Anchor::kLine) {
    a.state.T = s.T;
    a.state.rho = vapour ? s.rho_v : s.rho_l;
    a.state.dT_dh_p = a.state.drho_dh_p = T(0.0);  // along the line: everything through dp
    a.state.dT_dp_h = s.dT_dp;
    a.state.drho_dp_h = vapour ? s.drho_v_dp : s.drho_l_dp;
    a.de_dh = T(0.0);
  } else if (kind == Anchor::kBranchNear) {
    const T z = vapour ? T(h - s.h_v) : T(s.h_l - h);
    const T e = vapour ? T(s.h_v + smooth_max0(z, w)) : T(s.h_l - smooth_max0(z, w));
    const T slope = smooth_max0_slope(z, w);
    a.state = r32::ph_table().ph_in(p, e, vapour ? r32::Region::kVapour : r32::Region::kLiquid);
    a.de_dh = slope;
    a.de_dp = (1.0 - slope) * (vapour ? s.dh_v_dp : s.dh_l_dp);
  }
  return a;
}

// The cell's ends (values) at pressure p [Pa], enthalpies [J/kg], air temperature [K]. False if
// a state is outside the property table.
template <class T>
bool cell_ends(const T& p, const T& h_in, const T& h_out, const T& t_air, double w,
               CellEnds<T>& c) {
  const auto a = r32::ph_props(p, h_in);
  const auto b = r32::ph_props(p, h_out);
  const auto s = r32::sat_props(p);
  if (a.status != r32::Status::kOk || b.status != r32::Status::kOk || s.status != r32::Status::kOk)
    return false;
  const auto set = [&](const T& h, const r32::PhState<T>& own, bool vapour, T& temp, T& vol) {
    const AnchorState<T> x = anchor_state(p, h, own, s, vapour, w);
    temp = x.state.T;
    vol = 1.0 / x.state.rho;
  };
  c.h_in = h_in;
  c.h_out = h_out;
  set(h_in, a, true, c.T_in_v, c.v_in_v);
  set(h_in, a, false, c.T_in_l, c.v_in_l);
  set(h_out, b, true, c.T_out_v, c.v_out_v);
  set(h_out, b, false, c.T_out_l, c.v_out_l);
  c.T_sat = s.T;
  c.h_l = s.h_l;
  c.h_v = s.h_v;
  c.v_l = 1.0 / s.rho_l;
  c.v_v = 1.0 / s.rho_v;
  c.T_air = t_air;
  return true;
}

}  // namespace hvac_twin::plant::hp
