// Template bodies of HeatPumpR32 (included by heat_pump.hpp; not for direct use).
#pragma once

#include <type_traits>

#include "plant_models/core/tangent.hpp"
#include "plant_models/heat_pump/heat_pump.hpp"
#include "plant_models/heat_pump/hp_cell_ends.hpp"
#include "plant_models/refrigerant/r32_smooth.hpp"
#include "plant_models/zone/zone_rc.hpp"

namespace hvac_twin::plant {

inline constexpr double kKelvin = 273.15;
inline constexpr double kGramPerHour = 1e-3 / 3600.0;  // kg/s

template <class S>
HeatPumpR32::SideInputs<S> HeatPumpR32::side_inputs(std::span<const S> x,
                                                    std::span<const double> u) const {
  using std::exp;
  SideInputs<S> in;
  in.charge = x[L_.charge];
  in.m_cond = x[L_.m_cond];
  in.h_dl = 1e3 * x[L_.h_dl];
  in.h_ll = 1e3 * x[L_.h_ll];
  in.h_sl = 1e3 * x[L_.h_sl];
  for (std::size_t k = 0; k < n_; ++k) {
    in.h_cond[k] = 1e3 * x[L_.h_cond[k]];
    in.h_evap[k] = 1e3 * x[L_.h_evap[k]];
  }
  in.t_air = x[L_.t_air] + kKelvin;
  const hp::AirSide ac = hp::air_side(p_.cond, u[hp::kOutdoorFan], p_.fan_ua_exponent, n_);
  const hp::AirSide ae = hp::air_side(p_.evap, u[hp::kIndoorFan], p_.fan_ua_exponent, n_);
  in.g_cond = ac.capacity_rate * (1.0 - exp(-ac.ntu * factor(x, hp::kCondUa)));
  in.g_evap = ae.capacity_rate * (1.0 - exp(-ae.ntu * factor(x, hp::kEvapUa)));
  in.comp_flow = factor(x, hp::kCompFlow);
  in.void_exponent = factor(x, hp::kVoidExponent);
  in.cond_htc = factor(x, hp::kCondHtc);
  in.evap_htc = factor(x, hp::kEvapHtc);
  in.friction = factor(x, hp::kFriction);
  return in;
}

template <class A, class B, class F>
void HeatPumpR32::map_inputs(const SideInputs<A>& from, SideInputs<B>& to, F&& f) const {
  to.charge = f(from.charge);
  to.m_cond = f(from.m_cond);
  to.h_dl = f(from.h_dl);
  to.h_ll = f(from.h_ll);
  to.h_sl = f(from.h_sl);
  for (std::size_t k = 0; k < n_; ++k) {
    to.h_cond[k] = f(from.h_cond[k]);
    to.h_evap[k] = f(from.h_evap[k]);
  }
  to.t_air = f(from.t_air);
  to.g_cond = f(from.g_cond);
  to.g_evap = f(from.g_evap);
  to.comp_flow = f(from.comp_flow);
  to.void_exponent = f(from.void_exponent);
  to.cond_htc = f(from.cond_htc);
  to.evap_htc = f(from.evap_htc);
  to.friction = f(from.friction);
}

template <class A, class B, class F>
void HeatPumpR32::map_side(const Eval<A>& from, Eval<B>& to, F&& f) const {
  to.p_cond = f(from.p_cond);
  to.p_evap = f(from.p_evap);
  to.dp_cond = f(from.dp_cond);
  to.dp_evap = f(from.dp_evap);
  to.comp = {f(from.comp.mdot), f(from.comp.h_dis), f(from.comp.w_ref), f(from.comp.w_elec)};
  const auto line = [&f](const LineCell<A>& a) {
    return LineCell<B>{f(a.h), f(a.p), f(a.rho), f(a.rho_p), f(a.rho_h), f(a.T)};
  };
  to.dl = line(from.dl);
  to.ll = line(from.ll);
  to.sl = line(from.sl);
  for (std::size_t k = 0; k < n_; ++k) {
    map_cell(from.cond[k], to.cond[k], f);
    map_cell(from.evap[k], to.evap[k], f);
  }
}

template <class A, class B, class F>
void HeatPumpR32::map_cell(const CoilCell<A>& a, CoilCell<B>& to, F&& f) {
  to =
      CoilCell<B>{f(a.p),       f(a.T_in),    f(a.T_out),    f(a.h_l),      f(a.h_v),   f(a.mass),
                  f(a.mass_p),  f(a.mass_in), f(a.mass_out), f(a.mass_air), f(a.cap_p), f(a.cap_in),
                  f(a.cap_out), f(a.cap_air), f(a.alpha),    f(a.alpha_T)};
}

template <class T>
T HeatPumpR32::coil_cell(const T& p, const T& h_in, const T& h_out, const T& t_air,
                         const hp::CellScalars<T>& k, const hp::ProfileOptions& o, double volume,
                         std::size_t slot, CoilCell<T>* out) const {
  if constexpr (!kIsDual<T>) {
    // Values only: a jet at these inputs (a Jacobian's chunk that seeds no refrigerant state, or
    // the right-hand side at the state of the last Jacobian) already holds them.
    if (out != nullptr) {
      const CellJet& jet = cell_jets_[slot];
      if (jet.valid &&
          jet.key == std::array<double, kCellInputs>{p, h_in, h_out, t_air, k.g_air, k.alpha_factor,
                                                     k.void_exponent}) {
        map_cell(jet.cell, *out, [](const CellDual& q) { return q.v; });
        return out->mass;
      }
    }
    return coil_cell_direct(p, h_in, h_out, t_air, k, o, volume, out);
  } else {
    if (out == nullptr) return coil_cell_direct(p, h_in, h_out, t_air, k, o, volume, out);
    // The local jet (see CellJet): evaluated once per distinct input values, then chained.
    const std::array<const T*, kCellInputs> in{&p,       &h_in,           &h_out,          &t_air,
                                               &k.g_air, &k.alpha_factor, &k.void_exponent};
    CellJet& jet = cell_jets_[slot];
    bool same = jet.valid;
    for (int i = 0; i < kCellInputs; ++i)
      same = same && jet.key[static_cast<std::size_t>(i)] == in[static_cast<std::size_t>(i)]->v;
    if (!same) {
      std::array<CellDual, kCellInputs> z{};
      for (int i = 0; i < kCellInputs; ++i) {
        const auto ui = static_cast<std::size_t>(i);
        jet.key[ui] = in[ui]->v;
        z[ui] = CellDual(in[ui]->v);
        z[ui].d[ui] = 1.0;
      }
      const hp::CellScalars<CellDual> kz{z[4], z[5], z[6]};
      const CellDual mass = coil_cell_direct(z[0], z[1], z[2], z[3], kz, o, volume, &jet.cell);
      jet.valid = std::isfinite(mass.v);
      if (!jet.valid) return T(std::nan(""));
    }
    constexpr int M = T::kDirections;
    const auto chain = [&in](const CellDual& q) {
      T r(q.v);
      for (int i = 0; i < kCellInputs; ++i) {
        const double g = q.d[static_cast<std::size_t>(i)];
        if (g == 0.0) continue;
        const auto& di = in[static_cast<std::size_t>(i)]->d;
        for (int j = 0; j < M; ++j)
          r.d[static_cast<std::size_t>(j)] += g * di[static_cast<std::size_t>(j)];
      }
      return r;
    };
    map_cell(jet.cell, *out, chain);
    return out->mass;
  }
}

template <class T>
T HeatPumpR32::coil_cell_direct(const T& p, const T& h_in, const T& h_out, const T& t_air,
                                const hp::CellScalars<T>& k, const hp::ProfileOptions& o,
                                double volume, CoilCell<T>* out) const {
  if (out == nullptr) {  // the mass only
    hp::CellEnds<T> c;
    if (!hp::cell_ends(p, h_in, h_out, t_air, o.line_blend, c)) return T(std::nan(""));
    return volume * hp::cell_means(c, k, o).rho;
  }
  const auto a = r32::ph_props(p, h_in);
  const auto b = r32::ph_props(p, h_out);
  const auto s = r32::sat_props(p);
  if (a.status != r32::Status::kOk || b.status != r32::Status::kOk || s.status != r32::Status::kOk)
    return T(std::nan(""));
  // Where the vapour and liquid pieces end for each end (hp_cell_ends.hpp), in Tangent<4, T>:
  // the partials of those states in the cell pressure (direction 0) and in the end's enthalpy
  // (direction `dir`).
  using R = Tangent<4, T>;
  const auto anchor = [&](const T& h, const r32::PhState<T>& own, int dir, bool vapour, R& temp,
                          R& vol) {
    const hp::AnchorState<T> x = hp::anchor_state(p, h, own, s, vapour, o.line_blend);
    const r32::PhState<T>& st = x.state;
    const T v2 = -1.0 / (st.rho * st.rho);
    temp = R(st.T);
    vol = R(T(1.0 / st.rho));
    temp.d[0] = st.dT_dp_h + st.dT_dh_p * x.de_dp;
    vol.d[0] = v2 * (st.drho_dp_h + st.drho_dh_p * x.de_dp);
    temp.d[static_cast<std::size_t>(dir)] = st.dT_dh_p * x.de_dh;
    vol.d[static_cast<std::size_t>(dir)] = v2 * st.drho_dh_p * x.de_dh;
  };
  // The means in Tangent<4, T>: directions 0 the pressure level (the cell's friction offset
  // held), 1 the inlet enthalpy, 2 the outlet enthalpy, 3 the air temperature.
  const auto on_p = [](const T& v, const T& slope) {
    R r(v);
    r.d[0] = slope;
    return r;
  };
  hp::CellEnds<R> c;
  c.h_in = R::seed(h_in, 1);
  c.h_out = R::seed(h_out, 2);
  c.T_air = R::seed(t_air, 3);
  anchor(h_in, a, 1, true, c.T_in_v, c.v_in_v);
  anchor(h_in, a, 1, false, c.T_in_l, c.v_in_l);
  anchor(h_out, b, 2, true, c.T_out_v, c.v_out_v);
  anchor(h_out, b, 2, false, c.T_out_l, c.v_out_l);
  c.T_sat = on_p(s.T, s.dT_dp);
  c.h_l = on_p(s.h_l, s.dh_l_dp);
  c.h_v = on_p(s.h_v, s.dh_v_dp);
  c.v_l = on_p(T(1.0 / s.rho_l), T(-s.drho_l_dp / (s.rho_l * s.rho_l)));
  c.v_v = on_p(T(1.0 / s.rho_v), T(-s.drho_v_dp / (s.rho_v * s.rho_v)));
  const hp::CellMeans<R> m = hp::cell_means(c, k, o);
  CoilCell<T>& cell = *out;
  cell.p = p;
  cell.T_in = a.T;
  cell.T_out = b.T;
  cell.h_l = s.h_l;
  cell.h_v = s.h_v;
  cell.mass = volume * m.rho.v;
  cell.mass_p = volume * m.rho.d[0];
  cell.mass_in = volume * m.rho.d[1];
  cell.mass_out = volume * m.rho.d[2];
  cell.mass_air = volume * m.rho.d[3];
  cell.alpha = m.alpha.v;
  cell.alpha_T = m.alpha_T.v;
  // Energy capacities C_x = dH/dx - h_out dm/dx of the content H = (1 - b) m h_out + b V rho_h
  // (b = kProfileStorage): C_x = b V (d rho_h/dx - h_out d rho/dx) + (1 - b) m [x = h_out].
  const double share = hp::kProfileStorage;
  cell.cap_p = share * volume * (m.rho_h.d[0] - h_out * m.rho.d[0]);
  cell.cap_in = share * volume * (m.rho_h.d[1] - h_out * m.rho.d[1]);
  cell.cap_out = share * volume * (m.rho_h.d[2] - h_out * m.rho.d[2]) + (1.0 - share) * cell.mass;
  cell.cap_air = share * volume * (m.rho_h.d[3] - h_out * m.rho.d[3]);
  return cell.mass;
}

template <class T>
int HeatPumpR32::side_masses(const T& p_cond, const T& p_evap, const SideInputs<T>& in,
                             const Conditions& c, T& r_cond, T& r_evap, Eval<T>* e) const {
  using std::isfinite;
  using std::pow;
  const std::size_t N = n_;
  const auto line = [this](const T& p, const T& h, LineCell<T>& cell) {
    const auto s = r32::smooth_ph(p, h, p_.smoothing_width);
    cell = LineCell<T>{h, p, s.rho, s.drho_dp, s.drho_dh, s.T};
    return s.status == r32::Status::kOk;
  };
  LineCell<T> dl, ll, sl;
  bool ok = line(p_evap, in.h_sl, sl);  // the compressor inlet
  hp::CompressorFlow<T> comp = hp::compressor(p_, p_evap, sl.rho, in.h_sl, p_cond, c.speed);
  comp.mdot *= in.comp_flow;  // the efficiency factor acts in evaluate(): not on the masses
  comp.w_ref *= in.comp_flow;
  comp.w_elec *= in.comp_flow;
  const T drop = in.friction * pow(T(comp.mdot / p_.nominal_mass_flow), p_.dp_exponent);
  const T dp_cond = p_.cond.dp_nominal * drop;
  const T dp_evap = p_.evap.dp_nominal * drop;

  // The friction profile along each coil: the share of its drop upstream of each cell's middle.
  std::array<T, kMaxCells> w_cond{}, w_evap{};
  const double inv_n = 1.0 / static_cast<double>(N);
  if (p_.dp_distribution == 0) {
    for (std::size_t k = 0; k < N; ++k)
      w_cond[k] = w_evap[k] = T((static_cast<double>(k) + 0.5) * inv_n);
  } else {
    // In proportion to each cell's specific volume (friction ~ G^2 v), at the coil's pressure.
    const auto shares = [&](const T& p_ref, const std::array<T, kMaxCells>& h,
                            std::array<T, kMaxCells>& w) {
      T total(0.0);
      for (std::size_t k = 0; k < N; ++k) {
        const auto s = r32::ph_props(p_ref, h[k]);
        ok = ok && s.status == r32::Status::kOk;
        w[k] = 1.0 / s.rho;
        total += w[k];
      }
      T before(0.0);
      for (std::size_t k = 0; k < N; ++k) {
        const T own = w[k];
        w[k] = (before + 0.5 * own) / total;
        before += own;
      }
    };
    shares(p_cond, in.h_cond, w_cond);
    shares(p_evap, in.h_evap, w_evap);
  }

  ok = line(p_cond, in.h_dl, dl) && ok;
  ok = line(p_cond - dp_cond, in.h_ll, ll) && ok;
  if (!ok) return kModelRecoverable;
  const double v_cond = p_.cond.volume * inv_n, v_evap = p_.evap.volume * inv_n;
  const T t_out(c.t_out);
  const hp::CellScalars<T> k_cond{in.g_cond, in.cond_htc, in.void_exponent};
  const hp::CellScalars<T> k_evap{in.g_evap, in.evap_htc, in.void_exponent};
  T mass_cond = p_.discharge_line_volume * dl.rho + p_.liquid_line_volume * ll.rho;
  T mass_evap = p_.suction_line_volume * sl.rho;
  for (std::size_t k = 0; k < N; ++k) {
    const T& h_in = k == 0 ? in.h_dl : in.h_cond[k - 1];
    mass_cond += coil_cell(T(p_cond - dp_cond * w_cond[k]), h_in, in.h_cond[k], t_out, k_cond,
                           prof_cond_, v_cond, k, e != nullptr ? &e->cond[k] : nullptr);
    const T& h_in_e = k == 0 ? in.h_ll : in.h_evap[k - 1];
    mass_evap +=
        coil_cell(T(p_evap + dp_evap * (1.0 - w_evap[k])), h_in_e, in.h_evap[k], in.t_air, k_evap,
                  prof_evap_, v_evap, kMaxCells + k, e != nullptr ? &e->evap[k] : nullptr);
  }
  if (!isfinite(value_of(mass_cond)) || !isfinite(value_of(mass_evap))) return kModelRecoverable;
  r_cond = mass_cond - in.m_cond;
  r_evap = mass_evap - (in.charge - in.m_cond);
  if (e != nullptr) {
    e->p_cond = p_cond;
    e->p_evap = p_evap;
    e->dp_cond = dp_cond;
    e->dp_evap = dp_evap;
    e->comp = comp;
    e->dl = dl;
    e->ll = ll;
    e->sl = sl;
  }
  return kModelOk;
}

template <class S>
int HeatPumpR32::evaluate(std::span<const S> x, std::span<const double> u, Eval<S>& e) const {
  const std::size_t N = n_;
  const Conditions c{u[hp::kCompressorSpeed], u[hp::kOutdoorTemperature] + kKelvin};
  const SideInputs<S> si = side_inputs(x, u);
  double pc = 0.0, pe = 0.0;
  std::array<double, 4> J{};
  if constexpr (std::is_same_v<S, double>) {
    double rc = 0.0, re = 0.0;
    if (const int st = solve_pressures(si, c, pc, pe, J, false); st != kModelOk) return st;
    if (side_masses(pc, pe, si, c, rc, re, &e) != kModelOk) return kModelRecoverable;
    store_linearisation(si, e, J);
  } else {
    // Pressures in double (Newton, cached across the chunks of one Jacobian); their tangents by
    // the implicit-function theorem, dp/dx = -J^-1 dR/dx at fixed pressures. Every property is
    // evaluated once, in a scalar W with two more directions seeded in the pressures, and each
    // result's state tangents completed by the chain rule: dq/dx = q_x + q_p dp/dx.
    constexpr int K = S::kDirections;
    SideInputs<double> dv;
    map_inputs(si, dv, [](const S& v) { return value_of(v); });
    if (const int st = solve_pressures(dv, c, pc, pe, J, true); st != kModelOk) return st;
    bool seeded = false;
    for (std::size_t i = 0; i < L_.refrigerant_states && !seeded; ++i)
      for (const double d : x[i].d)
        seeded = seeded || d != 0.0;
    if (!seeded) {  // the chunk seeds only walls, zone mass or unknowns: no refrigerant tangents
      Eval<double> ed;
      double rcd = 0.0, red = 0.0;
      if (side_masses(pc, pe, dv, c, rcd, red, &ed) != kModelOk) return kModelRecoverable;
      map_side(ed, e, [](double v) { return S(v); });
    } else {
      using W = Dual<K + 2>;
      SideInputs<W> wi;
      map_inputs(si, wi, [](const S& v) {
        W w(v.v);
        for (int j = 0; j < K; ++j)
          w.d[static_cast<std::size_t>(j)] = v.d[static_cast<std::size_t>(j)];
        return w;
      });
      W pcw(pc), pew(pe), rcw{}, rew{};
      pcw.d[K] = 1.0;
      pew.d[K + 1] = 1.0;
      Eval<W> ew;
      if (side_masses(pcw, pew, wi, c, rcw, rew, &ew) != kModelOk) return kModelRecoverable;
      std::array<double, K> dpc{}, dpe{};  // J is the solve's, nonsingular
      for (std::size_t j = 0; j < static_cast<std::size_t>(K); ++j)
        pressure_move(J, rcw.d[j], rew.d[j], dpc[j], dpe[j]);
      map_side(ew, e, [&](const W& w) {
        S v(w.v);
        for (std::size_t j = 0; j < static_cast<std::size_t>(K); ++j)
          v.d[j] = w.d[j] + w.d[K] * dpc[j] + w.d[K + 1] * dpe[j];
        return v;
      });
    }
  }

  // The compressor's isentropic-efficiency factor: on the discharge enthalpy and the work.
  const S comp_efficiency = factor(x, hp::kCompWork);
  e.comp.h_dis = si.h_sl + (e.comp.h_dis - si.h_sl) / comp_efficiency;
  e.comp.w_ref = e.comp.w_ref / comp_efficiency;
  e.comp.w_elec = e.comp.w_elec / comp_efficiency;
  // Expansion valve between the liquid line and the evaporator inlet.
  e.mdot_valve = factor(x, hp::kValve) * hp::valve_flow(p_, u[hp::kValveOpening], e.ll.rho,
                                                        S(e.ll.p - (e.p_evap + e.dp_evap)));
  e.leak = L_.leak != hp::kNone ? x[L_.leak] * kGramPerHour : S(p_.leak_rate * kGramPerHour);
  e.q_int = L_.q_int != hp::kNone ? x[L_.q_int] : S(p_.internal_gains);
  e.cond_htc = si.cond_htc;
  e.evap_htc = si.evap_htc;
  e.t_air = x[L_.t_air];
  e.t_mass = x[L_.t_mass];
  e.g_cond = si.g_cond;
  e.g_evap = si.g_evap;

  // Heat: wall -> refrigerant from the profile means, air -> wall on the air side.
  const double area_c = prof_cond_.area, area_e = prof_evap_.area;
  const double t_out = u[hp::kOutdoorTemperature];
  e.q_zone = S(0.0);
  for (std::size_t k = 0; k < N; ++k) {
    const S& tw_c = x[L_.tw_cond[k]];
    const S& tw_e = x[L_.tw_evap[k]];
    e.q_cond[k] = area_c * ((tw_c + kKelvin) * e.cond[k].alpha - e.cond[k].alpha_T);
    e.q_evap[k] = area_e * ((tw_e + kKelvin) * e.evap[k].alpha - e.evap[k].alpha_T);
    e.q_cond_air[k] = e.g_cond * (t_out - tw_c);
    e.q_evap_air[k] = e.g_evap * (e.t_air - tw_e);
    e.q_zone -= e.q_evap_air[k];
  }
  ZoneRc::balance(p_.zone, e.t_air, e.t_mass, e.q_int, e.q_zone, t_out, e.t_air_dot, e.t_mass_dot);
  march_condenser(e, x);
  march_evaporator(e, x);
  return kModelOk;
}

// The cell balances of a side, marched in flow direction. Each cell's inflow is a + b pdot and
// its inlet enthalpy moves at e_in + f_in pdot (the upstream cell's). A coil cell holds the mass
// m(p, h_in, h, T_air) and the enthalpy H(p, h_in, h, T_air) of its profile; with the mass
// balance, the energy balance dH/dt - V dp/dt = inflow h_in - outflow h + Q becomes
//   C_h dh/dt = (a + b pdot)(h_in - h) + Q + X + (V - C_p) pdot - C_in dh_in/dt - C_air dT_air/dt
// with the capacities C_x = dH/dx - h dm/dx, so dh/dt = e + f pdot; and the outflow, inflow -
// dm/dt, is affine in pdot again. A line cell (uniform state) is the special case H = m h. The
// last outflow equals the downstream flow, which fixes pdot.
//
// X, back-mixing where the flow reverses. The balance above carries the upstream element's
// enthalpy across each face, right while the refrigerant flows forward. Where a face's flow F
// turns backward (the unit stopped: the valve shut, cells evaporating and condensing at rest,
// 1-3 g/s either way) it would carry the enthalpy of the element the flow leaves towards: the
// cells then pull away from their neighbours (anti-diffusion), the profile breaks into a
// checkerboard of liquid and vapour cells and the integrator stalls (the filter's predictions
// failed 30 min into the night stop). So each interior face also exchanges a mass w =
// softplus(-F) both ways, X_j = sum over its faces of w (h_neighbour - h_j): with w = -F the
// face carries the downstream element's enthalpy, upwind in the flow's direction. Equal masses
// both ways and opposite energies: mass and energy stay exactly conserved, the heat flows
// untouched. w is taken from a first march without X (so it stays a smooth function of the
// state); in operation every face flows forward by far more than the width, w is exactly 0 and
// the second march is skipped.
namespace hp_detail {

template <class S>
struct Affine {
  S a{}, b{};  // value a + b pdot
};

// The smoothing width of the back-mixing flow [kg/s]: 0.1 g/s, against 20-40 g/s in operation.
inline constexpr double kBackMixingWidth = 1e-4;

// A line cell: returns dh/dt = e + f pdot and updates the flow to the outflow; `mix` is X [W].
template <class S>
Affine<S> line_cell(Affine<S>& flow, const S& h_up, const S& h, const S& rho, const S& rho_p,
                    const S& rho_h, double volume, const S& mix) {
  const S vrho = volume * rho;
  Affine<S> hdot{(flow.a * (h_up - h) + mix) / vrho, (flow.b * (h_up - h) + volume) / vrho};
  flow.a = flow.a - volume * rho_h * hdot.a;
  flow.b = flow.b - volume * rho_p - volume * rho_h * hdot.b;
  return hdot;
}

// The enthalpies of a side's elements [J/kg]: `first`, the cells' (x in kJ/kg), `last`.
template <class S>
std::array<S, HeatPumpR32::kMaxCells + 2> element_enthalpies(const S& first, std::span<const S> x,
                                                             const hp::Slice& cells,
                                                             const S& last) {
  std::array<S, HeatPumpR32::kMaxCells + 2> h{};
  h[0] = first;
  for (std::size_t k = 0; k < cells.size; ++k)
    h[k + 1] = 1e3 * x[cells[k]];
  h[cells.size + 1] = last;
  return h;
}

// Adds the back-mixing X of the faces first..last-1 (face j: element j's outflow into element
// j + 1, affine in pdot) to mix; returns whether any face mixes.
template <class S, std::size_t M>
bool back_mixing(const std::array<S, M>& h, const std::array<Affine<S>, M>& outflow, const S& pdot,
                 std::size_t first, std::size_t last, std::array<S, M>& mix) {
  using std::exp;
  using std::log1p;
  bool any = false;
  for (std::size_t j = first; j < last; ++j) {
    const S z = -(outflow[j].a + outflow[j].b * pdot) / kBackMixingWidth;
    if (value_of(z) < -30.0) continue;  // w < 1e-17 kg/s
    const S w = value_of(z) > 30.0 ? S(z * kBackMixingWidth) : S(kBackMixingWidth * log1p(exp(z)));
    const S exchange = w * (h[j + 1] - h[j]);
    mix[j] = mix[j] + exchange;
    mix[j + 1] = mix[j + 1] - exchange;
    any = true;
  }
  return any;
}

}  // namespace hp_detail

template <class S>
void HeatPumpR32::march_condenser(Eval<S>& e, const std::span<const S> x) const {
  using hp_detail::Affine;
  const std::size_t N = n_;
  const double v_cell = p_.cond.volume / static_cast<double>(N);
  // Elements: 0 the discharge line, 1..N the cells, N + 1 the liquid line.
  const auto h = hp_detail::element_enthalpies(e.dl.h, x, L_.h_cond, e.ll.h);
  std::array<S, kMaxCells + 2> mix{};
  std::array<Affine<S>, kMaxCells + 2> hdot{}, outflow{};
  for (int pass = 0; pass < 2; ++pass) {
    Affine<S> flow{e.comp.mdot, S(0.0)};
    hdot[0] = hp_detail::line_cell(flow, e.comp.h_dis, h[0], e.dl.rho, e.dl.rho_p, e.dl.rho_h,
                                   p_.discharge_line_volume, mix[0]);
    outflow[0] = flow;
    for (std::size_t k = 0; k < N; ++k) {
      const CoilCell<S>& c = e.cond[k];
      const Affine<S>& in = hdot[k];
      Affine<S>& out = hdot[k + 1];
      // The outdoor air temperature is an input, constant over a step.
      out.a = (flow.a * (h[k] - h[k + 1]) + e.q_cond[k] + mix[k + 1] - c.cap_in * in.a) / c.cap_out;
      out.b = (flow.b * (h[k] - h[k + 1]) + v_cell - c.cap_p - c.cap_in * in.b) / c.cap_out;
      flow.a = flow.a - c.mass_in * in.a - c.mass_out * out.a;
      flow.b = flow.b - c.mass_p - c.mass_in * in.b - c.mass_out * out.b;
      outflow[k + 1] = flow;
    }
    hdot[N + 1] = hp_detail::line_cell(flow, h[N], h[N + 1], e.ll.rho, e.ll.rho_p, e.ll.rho_h,
                                       p_.liquid_line_volume, mix[N + 1]);
    e.pdot_cond = (e.mdot_valve - flow.a) / flow.b;
    // Faces 0..N: from the discharge line to the liquid line (the valve is not a face).
    if (pass == 1 || !hp_detail::back_mixing(h, outflow, e.pdot_cond, 0, N + 1, mix)) break;
  }
  e.hdot_dl = hdot[0].a + hdot[0].b * e.pdot_cond;
  for (std::size_t k = 0; k < N; ++k)
    e.hdot_cond[k] = hdot[k + 1].a + hdot[k + 1].b * e.pdot_cond;
  e.hdot_ll = hdot[N + 1].a + hdot[N + 1].b * e.pdot_cond;
}

template <class S>
void HeatPumpR32::march_evaporator(Eval<S>& e, const std::span<const S> x) const {
  using hp_detail::Affine;
  const std::size_t N = n_;
  const double v_cell = p_.evap.volume / static_cast<double>(N);
  // Elements: 0 the valve outlet (the liquid line's enthalpy), 1..N the cells, N + 1 the
  // suction line.
  const auto h = hp_detail::element_enthalpies(e.ll.h, x, L_.h_evap, e.sl.h);
  std::array<S, kMaxCells + 2> mix{};
  std::array<Affine<S>, kMaxCells + 2> hdot{}, outflow{};
  for (int pass = 0; pass < 2; ++pass) {
    Affine<S> flow{e.mdot_valve, S(0.0)};
    hdot[0] = Affine<S>{e.hdot_ll, S(0.0)};
    for (std::size_t k = 0; k < N; ++k) {
      const CoilCell<S>& c = e.evap[k];
      const Affine<S>& in = hdot[k];
      Affine<S>& out = hdot[k + 1];
      out.a = (flow.a * (h[k] - h[k + 1]) + e.q_evap[k] + mix[k + 1] - c.cap_in * in.a -
               c.cap_air * e.t_air_dot) /
              c.cap_out;
      out.b = (flow.b * (h[k] - h[k + 1]) + v_cell - c.cap_p - c.cap_in * in.b) / c.cap_out;
      flow.a = flow.a - c.mass_in * in.a - c.mass_out * out.a - c.mass_air * e.t_air_dot;
      flow.b = flow.b - c.mass_p - c.mass_in * in.b - c.mass_out * out.b;
      outflow[k + 1] = flow;
    }
    hdot[N + 1] = hp_detail::line_cell(flow, h[N], h[N + 1], e.sl.rho, e.sl.rho_p, e.sl.rho_h,
                                       p_.suction_line_volume, mix[N + 1]);
    e.pdot_evap = (S(e.comp.mdot + e.leak) - flow.a) / flow.b;
    // Faces 1..N: from the first cell to the suction line (the valve is not a face).
    if (pass == 1 || !hp_detail::back_mixing(h, outflow, e.pdot_evap, 1, N + 1, mix)) break;
  }
  for (std::size_t k = 0; k < N; ++k)
    e.hdot_evap[k] = hdot[k + 1].a + hdot[k + 1].b * e.pdot_evap;
  e.hdot_sl = hdot[N + 1].a + hdot[N + 1].b * e.pdot_evap;
}

template <class S>
HeatPumpR32::EndBalance<S> HeatPumpR32::end_balance(const Eval<S>& e, std::span<const S> x,
                                                    std::span<const double> u, hp::End end) const {
  using namespace hp;
  const std::size_t N = n_;
  const bool cond = end == kEndCondIn || end == kEndCondOut;
  const CoilCell<S>& c = end == kEndCondIn    ? e.cond[0]
                         : end == kEndCondOut ? e.cond[N - 1]
                         : end == kEndEvapIn  ? e.evap[0]
                                              : e.evap[N - 1];
  const ProfileOptions& o = cond ? prof_cond_ : prof_evap_;
  // The refrigerant at the end: its pressure and enthalpy.
  S p_end, h_end;
  switch (end) {
    case kEndCondIn:
      p_end = e.p_cond, h_end = e.dl.h;
      break;
    case kEndCondOut:
      p_end = e.ll.p, h_end = 1e3 * x[L_.h_cond.last()];
      break;
    case kEndEvapIn:
      p_end = S(e.p_evap + e.dp_evap), h_end = e.ll.h;
      break;
    default:
      p_end = e.p_evap, h_end = 1e3 * x[L_.h_evap.last()];
      break;
  }
  EndBalance<S> b;
  b.g = cond ? e.g_cond : e.g_evap;
  b.t_air = cond ? S(u[kOutdoorTemperature] + kKelvin) : S(e.t_air + kKelvin);
  b.t_ref = r32::ph_props(p_end, h_end).T;
  b.a = local_alpha(o, h_end, c.h_l, c.h_v, cond ? e.cond_htc : e.evap_htc) * o.area;
  b.mean = (o.area * c.alpha_T + b.g * b.t_air) / (o.area * c.alpha + b.g);
  return b;
}

template <class S>
int HeatPumpR32::rhs(std::span<const S> x, std::span<const double> u, std::span<S> xdot) const {
  Eval<S> e;
  if (const int st = evaluate(x, u, e); st != kModelOk) return st;
  const std::size_t N = n_;
  xdot[L_.charge] = -e.leak;
  xdot[L_.m_cond] = e.comp.mdot - e.mdot_valve;
  const double cw_c = p_.cond.wall_capacity / static_cast<double>(N);
  const double cw_e = p_.evap.wall_capacity / static_cast<double>(N);
  for (std::size_t k = 0; k < N; ++k) {
    xdot[L_.h_cond[k]] = 1e-3 * e.hdot_cond[k];
    xdot[L_.h_evap[k]] = 1e-3 * e.hdot_evap[k];
    xdot[L_.tw_cond[k]] = (e.q_cond_air[k] - e.q_cond[k]) / cw_c;
    xdot[L_.tw_evap[k]] = (e.q_evap_air[k] - e.q_evap[k]) / cw_e;
  }
  // The wall at a sensed end: a strip of the end cell's wall (the same capacity per area) in
  // balance with the refrigerant and the air there.
  const std::array<double, hp::kNumEnds> cw_end{cw_c, cw_c, cw_e, cw_e};
  for (std::size_t j = 0; j < L_.tw_end.size; ++j) {
    const EndBalance<S> b = end_balance(e, x, u, static_cast<hp::End>(j));
    const S tw = x[L_.tw_end[j]] + kKelvin;
    xdot[L_.tw_end[j]] = (b.a * (b.t_ref - tw) + b.g * (b.t_air - tw)) / cw_end[j];
  }
  xdot[L_.h_dl] = 1e-3 * e.hdot_dl;
  xdot[L_.h_ll] = 1e-3 * e.hdot_ll;
  xdot[L_.h_sl] = 1e-3 * e.hdot_sl;
  xdot[L_.t_air] = e.t_air_dot;
  xdot[L_.t_mass] = e.t_mass_dot;
  if (L_.q_int != hp::kNone) xdot[L_.q_int] = S(0.0);
  if (L_.leak != hp::kNone) xdot[L_.leak] = S(0.0);
  for (const std::size_t i : L_.factor)
    if (i != hp::kNone) xdot[i] = S(0.0);
  return kModelOk;
}

template <class S>
int HeatPumpR32::outputs(std::span<const S> x, std::span<const double> u, std::span<S> y) const {
  using namespace hp;
  Eval<S> e;
  if (const int st = evaluate(x, u, e); st != kModelOk) return st;
  const std::size_t N = n_;
  S q_cond{}, q_evap{}, capacity{};
  for (std::size_t k = 0; k < N; ++k) {
    q_cond -= e.q_cond[k];
    q_evap += e.q_evap[k];
    capacity += e.q_evap_air[k];
  }
  const auto sat_e = r32::sat_props(e.p_evap);
  const auto sat_ll = r32::sat_props(e.ll.p);
  const auto dis = r32::ph_props(e.p_cond, e.comp.h_dis);
  const AirSide air_e = air_side(p_.evap, u[kIndoorFan], p_.fan_ua_exponent, N);
  // The wall temperature a sensor at a coil's end reads: with end_walls, its own state; without,
  // the end cell's wall plus the difference between the local wall in steady balance with the
  // refrigerant at that end and the cell's mean wall in steady balance with its profile (exact
  // at steady state, but the difference moves without the wall's lag: convergence_bench's
  // dynamic section).
  const auto wall_at_end = [&](End end) -> S {
    if (L_.tw_end.size != 0) return x[L_.tw_end[end]];
    const EndBalance<S> b = end_balance(e, x, u, end);
    const S local = (b.a * b.t_ref + b.g * b.t_air) / (b.a + b.g);
    return x[L_.end_cell_wall(end)] + (local - b.mean);
  };
  y[kSuctionPressure] = e.p_evap;
  y[kDischargePressure] = e.p_cond;
  // What each wall sensor reads: the wall plus the sensor's offset (0 unless it is a state).
  y[kCondWallTempIn] = wall_at_end(kEndCondIn) + factor(x, hp::kCondInOffset);
  y[kCondWallTempOut] = wall_at_end(kEndCondOut) + factor(x, hp::kCondOutOffset);
  y[kEvapWallTempIn] = wall_at_end(kEndEvapIn) + factor(x, hp::kEvapInOffset);
  y[kEvapWallTempOut] = wall_at_end(kEndEvapOut) + factor(x, hp::kEvapOutOffset);
  y[kZoneAirTemperature] = e.t_air;
  y[kSupplyAirTemperature] = e.t_air - capacity / (air_e.capacity_rate * static_cast<double>(N));
  y[kCompressorPower] = e.comp.w_elec;
  y[kCondenserOutletPressure] = e.ll.p;
  y[kValveInletEnthalpy] = 1e-3 * e.ll.h;
  y[kCondenserHeatFlow] = q_cond;
  y[kEvaporatorHeatFlow] = q_evap;
  y[kCoolingCapacity] = capacity;
  y[kRefrigerantMassFlow] = e.comp.mdot;
  y[kDischargeTemperature] = dis.T - kKelvin;
  y[kSuperheat] = e.sl.T - sat_e.T;
  y[kSubcooling] = sat_ll.T - e.ll.T;
  y[kCop] = capacity / (e.comp.w_elec + 1.0);  // 1 W keeps it finite with the compressor off
  y[kCharge] = x[L_.charge];
  y[kLeakRate] = e.leak / kGramPerHour;
  y[kMassTemperature] = e.t_mass;
  y[kInternalGains] = e.q_int;
  y[kOutdoorCoilFouling] = factor(x, hp::kCondUa);
  return kModelOk;
}

}  // namespace hvac_twin::plant
