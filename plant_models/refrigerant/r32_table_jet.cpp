// The (p, h) table evaluated in Jets (value, gradient and Hessian in (p, h)) for the fused Dual<K>
// path (r32_table_jet.hpp). Mirrors r32_table_eval.hpp step by step: the same intervals, the same
// clamping, the same formulas; only the derivatives are carried in closed form.
#include <algorithm>
#include <cmath>

#include "plant_models/refrigerant/r32_table.hpp"

namespace hvac_twin::plant::r32 {

using table_detail::Basis2;
using table_detail::Jet;

PhTable::JetAt PhTable::locate_jet(double p) const {
  JetAt at;
  at.status = build_status_;
  if (!(p >= kPmin && p <= kPmax)) {
    if (at.status == Status::kOk) at.status = Status::kOutOfRange;
    p = std::isnan(p) ? kPmin : std::clamp(p, kPmin, kPmax);
    at.p_fixed = true;
  }
  const Jet eta = log(table_detail::jet_p(p));
  at.i = table_detail::find_interval(eta_.data(), table_detail::kNp, eta.v);
  const auto k = static_cast<std::size_t>(at.i);
  at.de = eta_[k + 1] - eta_[k];
  at.a = (eta - eta_[k]) * (1.0 / at.de);
  return at;
}

Jet PhTable::curve_jet(const table_detail::Curve& c, const JetAt& at, const Basis2& A) const {
  const auto k = static_cast<std::size_t>(at.i);
  return table_detail::hermite_jet(c.f[k], c.f[k + 1], c.f_e[k], c.f_e[k + 1], at.de, A, at.a);
}

void PhTable::single_jet(const table_detail::Node* nodes, const double* xi_nodes, int nx,
                         const JetAt& at, const Basis2& A, const Jet& h, const Jet& lo,
                         const Jet& hi, JetPh& out) const {
  const Jet xi = (h - lo) / (hi - lo);
  const int j = table_detail::find_interval(xi_nodes, nx, xi.v);
  const double dx = xi_nodes[j + 1] - xi_nodes[j];
  const Jet b = (xi - xi_nodes[j]) * (1.0 / dx);
  const Basis2 B(b.v);
  const int i = at.i;
  const table_detail::Node& n00 = nodes[i * nx + j];
  const table_detail::Node& n01 = nodes[i * nx + j + 1];
  const table_detail::Node& n10 = nodes[(i + 1) * nx + j];
  const table_detail::Node& n11 = nodes[(i + 1) * nx + j + 1];
  out.T = table_detail::patch_jet(n00.T, n01.T, n10.T, n11.T, at.de, dx, A, B, at.a, b);
  out.rho = exp(table_detail::patch_jet(n00.L, n01.L, n10.L, n11.L, at.de, dx, A, B, at.a, b));
}

void PhTable::region_jet(const JetAt& at, const Basis2& A, const Jet& h, const Jet& hl,
                         const Jet& hv, Region region, JetPh& out) const {
  out.region = region;
  if (region == Region::kLiquid) {
    single_jet(liquid_.data(), xi_l_.data(), table_detail::kNxL, at, A, h, curve_jet(h_min_, at, A),
               hl, out);
  } else if (region == Region::kVapour) {
    single_jet(vapour_.data(), xi_v_.data(), table_detail::kNxV, at, A, h, hv,
               curve_jet(h_max_, at, A), out);
  } else {
    // Two phase: T = T_sat(p); v = v_l + x (v_v - v_l) with x = (h - h_l)/(h_v - h_l).
    const Jet vl = exp(-curve_jet(ln_rho_l_, at, A));
    const Jet vv = exp(-curve_jet(ln_rho_v_, at, A));
    const Jet x = (h - hl) / (hv - hl);
    out.rho = reciprocal(vl + x * (vv - vl));
    out.T = curve_jet(t_sat_, at, A);
  }
  out.quality = (h - hl) / (hv - hl);
  out.h_l = hl;
  out.h_v = hv;
}

PhTable::JetPh PhTable::ph_jet(double p, double h_in) const {
  JetPh out;
  const JetAt at = locate_jet(p);
  out.status = at.status;
  out.p_fixed = at.p_fixed;
  if (build_status_ != Status::kOk) {
    out.empty = true;
    return out;
  }
  const Basis2 A(at.a.v);
  const Jet hl = curve_jet(h_l_, at, A);
  const Jet hv = curve_jet(h_v_, at, A);
  // A replaced h is a fresh variable at the boundary value (the partial-derivative outputs are
  // the table's partials there); its tangents follow the boundary curve (Seeds).
  const auto replace = [&out](double& h, const Jet& curve) {
    out.status = Status::kOutOfRange;
    out.h_fixed = true;
    out.dh_dp = curve.p;
    h = curve.v;
  };
  if (!std::isfinite(h_in)) replace(h_in, hl);
  Region region = Region::kTwoPhase;
  if (h_in < hl.v) {
    region = Region::kLiquid;
    const Jet lo = curve_jet(h_min_, at, A);
    if (h_in < lo.v) replace(h_in, lo);
  } else if (h_in > hv.v) {
    region = Region::kVapour;
    const Jet hi = curve_jet(h_max_, at, A);
    if (h_in > hi.v) replace(h_in, hi);
  }
  region_jet(at, A, table_detail::jet_h(h_in), hl, hv, region, out);
  return out;
}

PhTable::JetPh PhTable::ph_in_jet(double p, double h, Region region) const {
  JetPh out;
  const JetAt at = locate_jet(p);
  out.status = at.status;
  out.p_fixed = at.p_fixed;
  if (build_status_ != Status::kOk || !std::isfinite(h)) {
    if (build_status_ == Status::kOk) out.status = Status::kOutOfRange;
    out.empty = true;
    return out;
  }
  const Basis2 A(at.a.v);
  region_jet(at, A, table_detail::jet_h(h), curve_jet(h_l_, at, A), curve_jet(h_v_, at, A), region,
             out);
  return out;
}

PhTable::JetSat PhTable::sat_p_jet(double p) const {
  JetSat out;
  const JetAt at = locate_jet(p);
  out.status = at.status;
  out.p_fixed = at.p_fixed;
  if (build_status_ != Status::kOk) {
    out.empty = true;
    return out;
  }
  const Basis2 A(at.a.v);
  out.T = curve_jet(t_sat_, at, A);
  out.h_l = curve_jet(h_l_, at, A);
  out.h_v = curve_jet(h_v_, at, A);
  out.rho_l = exp(curve_jet(ln_rho_l_, at, A));
  out.rho_v = exp(curve_jet(ln_rho_v_, at, A));
  return out;
}

}  // namespace hvac_twin::plant::r32
