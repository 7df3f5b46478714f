// Template bodies of HeatPumpR32 (included by heat_pump.hpp; not for direct use).
#pragma once

#include <type_traits>

#include "plant_models/heat_pump/heat_pump.hpp"
#include "plant_models/refrigerant/r32_smooth.hpp"
#include "plant_models/zone/zone_rc.hpp"

namespace hvac_twin::plant {

inline constexpr double kKelvin = 273.15;
inline constexpr double kGramPerHour = 1e-3 / 3600.0;  // kg/s

template <class T>
int HeatPumpR32::fill_sides(const T& p_cond, const T& p_evap, const SideInputs<T>& in, double speed,
                            Eval<T>& e, T& r_cond, T& r_evap) const {
  const std::size_t N = n_;
  const auto cell = [this](const T& p, const T& h, Cell<T>& c) {
    const auto s = r32::smooth_ph(p, h, p_.smoothing_width);
    c = Cell<T>{h, p, s.rho, s.drho_dp, s.drho_dh, s.T, s.quality};
    return s.status == r32::Status::kOk;
  };
  bool ok = cell(p_evap, in.h_evap[N], e.evap[N]);  // suction line: the compressor inlet
  e.comp = hp::compressor(p_, p_evap, e.evap[N].rho, in.h_evap[N], p_cond, speed);
  const T flow = e.comp.mdot / p_.nominal_mass_flow;
  e.dp_cond = p_.cond.dp_nominal * flow * flow;
  e.dp_evap = p_.evap.dp_nominal * flow * flow;
  e.p_cond = p_cond;
  e.p_evap = p_evap;
  const double inv_n = 1.0 / static_cast<double>(N);
  for (std::size_t k = 0; k < N; ++k) {
    const double along = (static_cast<double>(k) + 0.5) * inv_n;
    ok = cell(p_cond - e.dp_cond * along, in.h_cond[k], e.cond[k]) && ok;
    ok = cell(p_evap + e.dp_evap * (1.0 - along), in.h_evap[k], e.evap[k]) && ok;
  }
  ok = cell(p_cond - e.dp_cond, in.h_cond[N], e.cond[N]) && ok;  // liquid line
  if (!ok) return kModelRecoverable;
  T mass_cond = p_.liquid_line_volume * e.cond[N].rho;
  T mass_evap = p_.suction_line_volume * e.evap[N].rho;
  for (std::size_t k = 0; k < N; ++k) {
    mass_cond += (p_.cond.volume * inv_n) * e.cond[k].rho;
    mass_evap += (p_.evap.volume * inv_n) * e.evap[k].rho;
  }
  r_cond = mass_cond - in.m_cond;
  r_evap = mass_evap - (in.charge - in.m_cond);
  return kModelOk;
}

template <class S>
void HeatPumpR32::chain_pressures(const Eval<Dual<2>>& at_p, const S& dpc, const S& dpe,
                                  Eval<S>& e) const {
  const auto add = [&](const Dual<2>& by_p, S& f) { f += by_p.d[0] * dpc + by_p.d[1] * dpe; };
  const auto cell = [&](const Cell<Dual<2>>& c2, Cell<S>& c) {
    add(c2.p, c.p);
    add(c2.rho, c.rho);
    add(c2.rho_p, c.rho_p);
    add(c2.rho_h, c.rho_h);
    add(c2.T, c.T);
    add(c2.quality, c.quality);
  };
  for (std::size_t k = 0; k <= n_; ++k) {
    cell(at_p.cond[k], e.cond[k]);
    cell(at_p.evap[k], e.evap[k]);
  }
  add(at_p.comp.mdot, e.comp.mdot);
  add(at_p.comp.h_dis, e.comp.h_dis);
  add(at_p.comp.w_ref, e.comp.w_ref);
  add(at_p.comp.w_elec, e.comp.w_elec);
  add(at_p.dp_cond, e.dp_cond);
  add(at_p.dp_evap, e.dp_evap);
  e.p_cond += dpc;
  e.p_evap += dpe;
}

template <class S>
void HeatPumpR32::promote(const Eval<double>& from, Eval<S>& to) const {
  const auto cell = [](const Cell<double>& c) {
    return Cell<S>{S(c.h), S(c.p), S(c.rho), S(c.rho_p), S(c.rho_h), S(c.T), S(c.quality)};
  };
  to.p_cond = S(from.p_cond);
  to.p_evap = S(from.p_evap);
  to.dp_cond = S(from.dp_cond);
  to.dp_evap = S(from.dp_evap);
  to.comp = {S(from.comp.mdot), S(from.comp.h_dis), S(from.comp.w_ref), S(from.comp.w_elec)};
  for (std::size_t k = 0; k <= n_; ++k) {
    to.cond[k] = cell(from.cond[k]);
    to.evap[k] = cell(from.evap[k]);
  }
}

template <class S>
void HeatPumpR32::march(std::span<Cell<S>> cells, std::span<const S> q, double v_cell,
                        double v_line, const S& mdot_in, const S& h_in, const S& mdot_out,
                        std::span<S> hdot, S& pdot) const {
  // Cell k with inflow a + b pdot at enthalpy h_up (upwind; forward flow):
  //   V rho dh/dt = (a + b pdot)(h_up - h) + Q + V pdot          energy
  //   V (rho_p pdot + rho_h dh/dt) = inflow - outflow              mass
  // so dh/dt = e + f pdot and the outflow is again affine in pdot. The last outflow must equal
  // mdot_out, which fixes pdot.
  const std::size_t n = cells.size();
  std::array<S, kMaxCells + 1> f{};
  S a = mdot_in;
  S b = S(0.0);
  S h_up = h_in;
  for (std::size_t k = 0; k < n; ++k) {
    const Cell<S>& c = cells[k];
    const bool line = k + 1 == n;
    const double v = line ? v_line : v_cell;
    const S heat = line ? S(0.0) : q[k];
    const S vrho = v * c.rho;
    hdot[k] = (a * (h_up - c.h) + heat) / vrho;
    f[k] = (b * (h_up - c.h) + v) / vrho;
    a = a - v * c.rho_h * hdot[k];
    b = b - v * c.rho_p - v * c.rho_h * f[k];
    h_up = c.h;
  }
  pdot = (mdot_out - a) / b;
  for (std::size_t k = 0; k < n; ++k)
    hdot[k] += f[k] * pdot;
}

template <class S>
int HeatPumpR32::evaluate(std::span<const S> x, std::span<const double> u, Eval<S>& e) const {
  const std::size_t N = n_;
  const double speed = u[hp::kCompressorSpeed];

  SideInputs<double> dv;
  dv.charge = value_of(x[L_.charge]);
  dv.m_cond = value_of(x[L_.m_cond]);
  for (std::size_t k = 0; k < N; ++k) {
    dv.h_cond[k] = 1e3 * value_of(x[L_.h_cond[k]]);
    dv.h_evap[k] = 1e3 * value_of(x[L_.h_evap[k]]);
  }
  dv.h_cond[N] = 1e3 * value_of(x[L_.h_ll]);
  dv.h_evap[N] = 1e3 * value_of(x[L_.h_sl]);
  double pc = 0.0, pe = 0.0;
  std::array<double, 4> J{};
  if (const int st = solve_pressures(dv, speed, pc, pe, J); st != kModelOk) return st;

  S r_cond{}, r_evap{};
  // With dual numbers seeded only in states the property solve does not read (walls, zone,
  // unknowns), the refrigerant side has no tangents: evaluate it in double and promote.
  bool plain = std::is_same_v<S, double>;
  if constexpr (!std::is_same_v<S, double>) {
    plain = true;
    for (std::size_t i = 0; i < L_.refrigerant_states && plain; ++i)
      for (const double d : x[i].d)
        plain = plain && d == 0.0;
  }
  if (plain) {
    if constexpr (std::is_same_v<S, double>) {
      if (fill_sides(pc, pe, dv, speed, e, r_cond, r_evap) != kModelOk) return kModelRecoverable;
    } else {
      Eval<double> ed;
      double rc = 0.0, re = 0.0;
      if (fill_sides(pc, pe, dv, speed, ed, rc, re) != kModelOk) return kModelRecoverable;
      promote(ed, e);
    }
  } else {
    SideInputs<S> sv;
    sv.charge = x[L_.charge];
    sv.m_cond = x[L_.m_cond];
    for (std::size_t k = 0; k < N; ++k) {
      sv.h_cond[k] = 1e3 * x[L_.h_cond[k]];
      sv.h_evap[k] = 1e3 * x[L_.h_evap[k]];
    }
    sv.h_cond[N] = 1e3 * x[L_.h_ll];
    sv.h_evap[N] = 1e3 * x[L_.h_sl];
    // One Newton step in the dual scalar at the converged pressures: its tangents are the
    // implicit-function derivatives -J^-1 dR/dx of the pressures.
    if (fill_sides(S(pc), S(pe), sv, speed, e, r_cond, r_evap) != kModelOk)
      return kModelRecoverable;
    const double det = J[0] * J[3] - J[1] * J[2];
    const S dpc = -(J[3] * r_cond - J[1] * r_evap) / det;
    const S dpe = -(J[0] * r_evap - J[2] * r_cond) / det;
    // The properties were evaluated at the pressures held fixed; add their dependence on the
    // pressures by the chain rule, dF += dF/dp_c dp_c + dF/dp_e dp_e, with dF/dp from the
    // Newton solve's last evaluation (seeded in both pressures, friction included).
    chain_pressures(*pressure_eval_, dpc, dpe, e);
  }

  // Expansion valve between the liquid line and the evaporator inlet.
  e.mdot_valve = hp::valve_flow(p_, u[hp::kValveOpening], e.cond[N].rho,
                                S(e.cond[N].p - (e.p_evap + e.dp_evap)));
  e.leak = L_.leak != hp::kNone ? x[L_.leak] * kGramPerHour : S(p_.leak_rate * kGramPerHour);
  e.q_int = L_.q_int != hp::kNone ? x[L_.q_int] : S(p_.internal_gains);
  e.fouling = L_.fouling != hp::kNone ? x[L_.fouling] : S(p_.fouling);
  e.t_air = x[L_.t_air];
  e.t_mass = x[L_.t_mass];

  // Heat transfer: refrigerant <-> wall <-> air, per cell.
  const hp::AirSide air_c = hp::air_side(p_.cond, u[hp::kOutdoorFan], p_.fan_ua_exponent, N);
  const hp::AirSide air_e = hp::air_side(p_.evap, u[hp::kIndoorFan], p_.fan_ua_exponent, N);
  const double area_c = p_.cond.inner_area / static_cast<double>(N);
  const double area_e = p_.evap.inner_area / static_cast<double>(N);
  const S t_out = S(u[hp::kOutdoorTemperature]);
  e.q_zone = S(0.0);
  for (std::size_t k = 0; k < N; ++k) {
    const S& tw_c = x[L_.tw_cond[k]];
    const S& tw_e = x[L_.tw_evap[k]];
    const S htc_c = hp::heat_transfer_coefficient(p_, p_.cond.htc_two_phase, e.cond[k].quality);
    const S htc_e = hp::heat_transfer_coefficient(p_, p_.evap.htc_two_phase, e.evap[k].quality);
    e.q_cond[k] = htc_c * area_c * (tw_c - (e.cond[k].T - kKelvin));
    e.q_evap[k] = htc_e * area_e * (tw_e - (e.evap[k].T - kKelvin));
    e.q_cond_air[k] = hp::air_to_wall(air_c, e.fouling, t_out, tw_c);
    e.q_evap_air[k] = hp::air_to_wall(air_e, S(1.0), e.t_air, tw_e);
    e.q_zone -= e.q_evap_air[k];
  }

  march(std::span<Cell<S>>(e.cond.data(), N + 1), std::span<const S>(e.q_cond.data(), N),
        p_.cond.volume / static_cast<double>(N), p_.liquid_line_volume, e.comp.mdot, e.comp.h_dis,
        e.mdot_valve, std::span<S>(e.hdot_cond.data(), N + 1), e.pdot_cond);
  march(std::span<Cell<S>>(e.evap.data(), N + 1), std::span<const S>(e.q_evap.data(), N),
        p_.evap.volume / static_cast<double>(N), p_.suction_line_volume, e.mdot_valve, e.cond[N].h,
        S(e.comp.mdot + e.leak), std::span<S>(e.hdot_evap.data(), N + 1), e.pdot_evap);
  return kModelOk;
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
  xdot[L_.h_ll] = 1e-3 * e.hdot_cond[N];
  xdot[L_.h_sl] = 1e-3 * e.hdot_evap[N];
  ZoneRc::balance(p_.zone, e.t_air, e.t_mass, e.q_int, e.q_zone, u[hp::kOutdoorTemperature],
                  xdot[L_.t_air], xdot[L_.t_mass]);
  if (L_.q_int != hp::kNone) xdot[L_.q_int] = S(0.0);
  if (L_.leak != hp::kNone) xdot[L_.leak] = S(0.0);
  if (L_.fouling != hp::kNone) xdot[L_.fouling] = S(0.0);
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
  const auto sat_ll = r32::sat_props(e.cond[N].p);
  const auto dis = r32::ph_props(e.p_cond, e.comp.h_dis);
  const AirSide air_e = air_side(p_.evap, u[kIndoorFan], p_.fan_ua_exponent, N);
  y[kSuctionPressure] = e.p_evap;
  y[kDischargePressure] = e.p_cond;
  y[kCondWallTempIn] = x[L_.tw_cond[0]];
  y[kCondWallTempOut] = x[L_.tw_cond.last()];
  y[kEvapWallTempIn] = x[L_.tw_evap[0]];
  y[kEvapWallTempOut] = x[L_.tw_evap.last()];
  y[kZoneAirTemperature] = e.t_air;
  y[kSupplyAirTemperature] = e.t_air - capacity / (air_e.capacity_rate * static_cast<double>(N));
  y[kCompressorPower] = e.comp.w_elec;
  y[kCondenserOutletPressure] = e.cond[N].p;
  y[kValveInletEnthalpy] = 1e-3 * e.cond[N].h;
  y[kCondenserHeatFlow] = q_cond;
  y[kEvaporatorHeatFlow] = q_evap;
  y[kCoolingCapacity] = capacity;
  y[kRefrigerantMassFlow] = e.comp.mdot;
  y[kDischargeTemperature] = dis.T - kKelvin;
  y[kSuperheat] = e.evap[N].T - sat_e.T;
  y[kSubcooling] = sat_ll.T - e.cond[N].T;
  y[kCop] = capacity / (e.comp.w_elec + 1.0);  // 1 W keeps it finite with the compressor off
  y[kCharge] = x[L_.charge];
  y[kLeakRate] = e.leak / kGramPerHour;
  y[kMassTemperature] = e.t_mass;
  y[kInternalGains] = e.q_int;
  y[kOutdoorCoilFouling] = e.fouling;
  return kModelOk;
}

}  // namespace hvac_twin::plant
