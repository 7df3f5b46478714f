// Template bodies of the (p, h) table evaluation (included by r32_table.hpp; not for direct use).
#pragma once

#include <algorithm>
#include <cmath>

#include "plant_models/refrigerant/r32_table.hpp"

namespace hvac_twin::plant::r32 {
namespace table_detail {

// One single-phase table at (p, h), given the pressure interval i (length de, basis A) and the
// lower/upper enthalpy boundary curves of the region at p (values and d/deta).
template <class S>
void eval_single(const Node* nodes, const double* xi_nodes, int nx, int i, double de,
                 const Basis<S>& A, const S& p, const S& h, const S& h_lo, const S& h_lo_e,
                 const S& h_hi, const S& h_hi_e, PhState<S>& out) {
  using std::exp;
  const S D = h_hi - h_lo;
  const S xi = (h - h_lo) / D;
  const int j = find_interval(xi_nodes, nx, value_of(xi));
  const auto dx = xi_nodes[j + 1] - xi_nodes[j];
  const Basis<S> B((xi - xi_nodes[j]) / dx);
  const Node& n00 = nodes[i * nx + j];
  const Node& n01 = nodes[i * nx + j + 1];
  const Node& n10 = nodes[(i + 1) * nx + j];
  const Node& n11 = nodes[(i + 1) * nx + j + 1];
  S T, T_e, T_x, L, L_e, L_x;
  patch(&n00.T, &n01.T, &n10.T, &n11.T, de, dx, A, B, T, T_e, T_x);
  patch(&n00.L, &n01.L, &n10.L, &n11.L, de, dx, A, B, L, L_e, L_x);
  // Chain rule from (eta, xi) to (p, h): xi_h = 1/D, xi_eta = -(h_lo_e + xi D_e)/D, eta_p = 1/p.
  const S xi_e = -(h_lo_e + xi * (h_hi_e - h_lo_e)) / D;
  const S inv_p = 1.0 / p;
  out.T = T;
  out.dT_dp_h = (T_e + T_x * xi_e) * inv_p;
  out.dT_dh_p = T_x / D;
  out.rho = exp(L);
  out.drho_dp_h = out.rho * (L_e + L_x * xi_e) * inv_p;
  out.drho_dh_p = out.rho * L_x / D;
}

}  // namespace table_detail

template <class S>
PhTable::Located<S> PhTable::locate(const S& p_in) const {
  using std::log;
  Located<S> at;
  at.status = build_status_;
  at.p = p_in;
  const double pv = value_of(p_in);
  if (!(pv >= kPmin && pv <= kPmax)) {
    if (at.status == Status::kOk) at.status = Status::kOutOfRange;
    at.p = S(std::isnan(pv) ? kPmin : std::clamp(pv, kPmin, kPmax));
  }
  const S eta = log(at.p);
  at.i = table_detail::find_interval(eta_.data(), table_detail::kNp, value_of(eta));
  const auto k = static_cast<std::size_t>(at.i);
  at.de = eta_[k + 1] - eta_[k];
  at.a = (eta - eta_[k]) / at.de;
  return at;
}

template <class S>
void PhTable::eval_region(const Located<S>& at, const table_detail::Basis<S>& A, const S& h,
                          const S& hl, const S& hl_e, const S& hv, const S& hv_e, Region region,
                          PhState<S>& out) const {
  using std::exp;
  using table_detail::curve_at;
  out.region = region;
  if (region == Region::kLiquid) {
    S lo, lo_e;
    curve_at(h_min_, at.i, at.de, A, lo, lo_e);
    table_detail::eval_single(liquid_.data(), xi_l_.data(), table_detail::kNxL, at.i, at.de, A,
                              at.p, h, lo, lo_e, hl, hl_e, out);
  } else if (region == Region::kVapour) {
    S hi, hi_e;
    curve_at(h_max_, at.i, at.de, A, hi, hi_e);
    table_detail::eval_single(vapour_.data(), xi_v_.data(), table_detail::kNxV, at.i, at.de, A,
                              at.p, h, hv, hv_e, hi, hi_e, out);
  } else {
    // Two phase: T = T_sat(p); v = v_l + x (v_v - v_l) with x = (h - h_l)/(h_v - h_l).
    S Ts, Ts_e, Ll, Ll_e, Lv, Lv_e;
    curve_at(t_sat_, at.i, at.de, A, Ts, Ts_e);
    curve_at(ln_rho_l_, at.i, at.de, A, Ll, Ll_e);
    curve_at(ln_rho_v_, at.i, at.de, A, Lv, Lv_e);
    const S vl = exp(-Ll);
    const S vv = exp(-Lv);
    const S dh = hv - hl;
    const S x = (h - hl) / dh;
    const S x_e = -(hl_e + x * (hv_e - hl_e)) / dh;
    const S v = vl + x * (vv - vl);
    const S v_e = -vl * Ll_e + x_e * (vv - vl) + x * (vl * Ll_e - vv * Lv_e);
    out.rho = 1.0 / v;
    out.drho_dp_h = -out.rho * out.rho * v_e / at.p;
    out.drho_dh_p = -out.rho * out.rho * (vv - vl) / dh;
    out.T = Ts;
    out.dT_dp_h = Ts_e / at.p;
    out.dT_dh_p = S(0.0);
  }
  out.quality = (h - hl) / (hv - hl);
  out.h_l = hl;
  out.h_v = hv;
}

template <class S>
PhState<S> PhTable::ph_by_operations(const S& p_in, const S& h_in) const {
  using table_detail::curve_at;
  PhState<S> out;
  const Located<S> at = locate(p_in);
  out.status = at.status;
  if (build_status_ != Status::kOk) return out;
  const table_detail::Basis<S> A(at.a);
  S hl, hl_e, hv, hv_e;
  curve_at(h_l_, at.i, at.de, A, hl, hl_e);
  curve_at(h_v_, at.i, at.de, A, hv, hv_e);

  S h = h_in;
  if (!std::isfinite(value_of(h))) {
    out.status = Status::kOutOfRange;
    h = hl;
  }
  const double hval = value_of(h);
  Region region = Region::kTwoPhase;
  if (hval < value_of(hl)) {
    region = Region::kLiquid;
    S lo, lo_e;
    curve_at(h_min_, at.i, at.de, A, lo, lo_e);
    if (hval < value_of(lo)) {
      out.status = Status::kOutOfRange;
      h = lo;
    }
  } else if (hval > value_of(hv)) {
    region = Region::kVapour;
    S hi, hi_e;
    curve_at(h_max_, at.i, at.de, A, hi, hi_e);
    if (hval > value_of(hi)) {
      out.status = Status::kOutOfRange;
      h = hi;
    }
  }
  eval_region(at, A, h, hl, hl_e, hv, hv_e, region, out);
  return out;
}

template <class S>
PhState<S> PhTable::ph_in_by_operations(const S& p_in, const S& h, Region region) const {
  using table_detail::curve_at;
  PhState<S> out;
  const Located<S> at = locate(p_in);
  out.status = at.status;
  if (build_status_ != Status::kOk) return out;
  if (!std::isfinite(value_of(h))) {
    out.status = Status::kOutOfRange;
    return out;
  }
  const table_detail::Basis<S> A(at.a);
  S hl, hl_e, hv, hv_e;
  curve_at(h_l_, at.i, at.de, A, hl, hl_e);
  curve_at(h_v_, at.i, at.de, A, hv, hv_e);
  eval_region(at, A, h, hl, hl_e, hv, hv_e, region, out);
  return out;
}

template <class S>
SatState<S> PhTable::sat_p_by_operations(const S& p_in) const {
  using std::exp;
  using table_detail::curve_at;
  SatState<S> out;
  const Located<S> at = locate(p_in);
  out.status = at.status;
  if (build_status_ != Status::kOk) return out;
  const table_detail::Basis<S> A(at.a);
  S T_e, hl_e, hv_e, Ll, Ll_e, Lv, Lv_e;
  curve_at(t_sat_, at.i, at.de, A, out.T, T_e);
  curve_at(h_l_, at.i, at.de, A, out.h_l, hl_e);
  curve_at(h_v_, at.i, at.de, A, out.h_v, hv_e);
  curve_at(ln_rho_l_, at.i, at.de, A, Ll, Ll_e);
  curve_at(ln_rho_v_, at.i, at.de, A, Lv, Lv_e);
  const S inv_p = 1.0 / at.p;
  out.rho_l = exp(Ll);
  out.rho_v = exp(Lv);
  out.dT_dp = T_e * inv_p;
  out.dh_l_dp = hl_e * inv_p;
  out.dh_v_dp = hv_e * inv_p;
  out.drho_l_dp = out.rho_l * Ll_e * inv_p;
  out.drho_v_dp = out.rho_v * Lv_e * inv_p;
  return out;
}

}  // namespace hvac_twin::plant::r32
