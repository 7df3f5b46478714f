// R32 density on (p, h) smoothed across the bubble and dew lines, for finite-volume models.
//
// Why: drho/dh|p jumps 10-60x at the bubble line (and ~2x at the dew line). A finite-volume
// model's right-hand side contains drho/dh, so with the raw table it is discontinuous wherever a
// cell crosses a saturation line: Newton iterations fail, steps are rejected, the cell
// "chatters". Near each line the true density is the minimum of the two neighbouring branches
// (the liquid table continued past h_l and the two-phase lever rule continued to x < 0 meet at
// the bubble line with different slopes; likewise two-phase and vapour at the dew line). The
// smoothed density replaces that minimum by a soft minimum
//     rho_s = min(a, b) - w ln(1 + exp(-|a - b| / w)),
// whose slopes are convex combinations of the branch slopes, so rho_s stays monotone in h, is
// C-infinity across the line, and its partial derivatives are exact (given below, including the
// dependence of w on p). The width w [kg/m^3] is chosen so that the transition spans about
// `width_h` of enthalpy: w = width_h * |drho/dh| of the two-phase branch at the line.
// The price: near a line the density is lowered by at most w ln 2, only within a few width_h of
// the line. At width_h = 300 J/kg that is 2.8 % at the bubble line at 0.9 MPa, 1.1 % at 2.5 MPa
// (8 % at 0.3 MPa, below any heat-pump operating point) and under 0.3 % at the dew line; the
// mass it moves is a fraction of one cell's, and only while that cell crosses the line.
//
// width_h = 0 returns the raw table (for comparisons). Units SI as r32_table.hpp. Templated on the
// scalar (double or Dual<K>): the partials carry exact tangents too. No allocation, no exceptions;
// thread-safe (reads the shared table).
#pragma once

#include <cmath>

#include "plant_models/core/dual.hpp"
#include "plant_models/refrigerant/r32_table.hpp"

namespace hvac_twin::plant::r32 {

inline constexpr double kDefaultSmoothingWidth = 300.0;  // J/kg
inline constexpr double kSmoothingWindow = 20.0;  // branches are blended within this many widths

template <class S>
struct SmoothState {
  Status status = Status::kOk;
  Region region = Region::kLiquid;  // of the raw table
  S T{};                            // K (raw table: continuous, with its kinks at the lines)
  S quality{};                      // (h - h_l)/(h_v - h_l), raw
  S rho{};                          // kg/m^3, smoothed
  S drho_dp{};                      // kg/(m^3 Pa) at constant h, exact partial of rho
  S drho_dh{};                      // kg^2/(m^3 J) at constant p, exact partial of rho
};

namespace smooth_detail {

// Soft minimum of a and b with width w, and its partials with respect to a, b and w.
template <class S>
struct SoftMin {
  S value, da, db, dw;
};

template <class S>
SoftMin<S> soft_min(const S& a, const S& b, const S& w) {
  using std::exp;
  using std::log1p;
  const S c = a - b;
  const bool a_lower = value_of(c) < 0.0;
  const S abs_c = a_lower ? -c : c;
  const S e = exp(-abs_c / w);
  SoftMin<S> r;
  r.value = (a_lower ? a : b) - w * log1p(e);
  const S lower_weight = 1.0 / (1.0 + e);  // weight of the lower branch
  r.da = a_lower ? lower_weight : 1.0 - lower_weight;
  r.db = 1.0 - r.da;
  r.dw = -log1p(e) - (abs_c / w) * e * lower_weight;
  return r;
}

}  // namespace smooth_detail

template <class S>
SmoothState<S> smooth_ph(const S& p, const S& h, double width_h = kDefaultSmoothingWidth) {
  const PhTable& table = ph_table();
  const PhState<S> raw = table.ph(p, h);
  SmoothState<S> out;
  out.status = raw.status;
  out.region = raw.region;
  out.T = raw.T;
  out.quality = raw.quality;
  out.rho = raw.rho;
  out.drho_dp = raw.drho_dp_h;
  out.drho_dh = raw.drho_dh_p;
  if (raw.status != Status::kOk || width_h <= 0.0) return out;  // width 0: the raw table

  // Far from both lines (the common case) the raw table is the answer.
  const double hv_ = value_of(h);
  const bool bubble_side = hv_ < 0.5 * (value_of(raw.h_l) + value_of(raw.h_v));
  const double distance = bubble_side ? hv_ - value_of(raw.h_l) : hv_ - value_of(raw.h_v);
  if (std::abs(distance) > kSmoothingWindow * width_h) return out;
  const SatState<S> sat = table.sat_p(p);
  const S hfg = sat.h_v - sat.h_l;
  const S d = bubble_side ? h - sat.h_l : h - sat.h_v;

  // Width from the two-phase slope at the line; its relative p-derivative by the chain rule:
  //   bubble: w = width_h rho_l (rho_l - rho_v) / (rho_v hfg)
  //   dew:    w = width_h rho_v (rho_l - rho_v) / (rho_l hfg)
  const S& A = sat.rho_l;
  const S& B = sat.rho_v;
  const S dA = sat.drho_l_dp, dB = sat.drho_v_dp, dH = sat.dh_v_dp - sat.dh_l_dp;
  const S common = (dA - dB) / (A - B) - dH / hfg;
  const S w = bubble_side ? width_h * A * (A - B) / (B * hfg) : width_h * B * (A - B) / (A * hfg);
  const S dlogw_dp = bubble_side ? dA / A - dB / B + common : dB / B - dA / A + common;
  const S dw_dp = w * dlogw_dp;

  // The two branches meeting at this line, continued across it. The lever rule continued below
  // the bubble line reaches v = 0 within a few kJ/kg at low pressure, so there the two-phase
  // branch is continued by its second-order expansion, rho_l (1 + u + u^2) with
  // u = s d / rho_l and s = -w / width_h its slope at the line: it matches the lever rule's
  // value, slope and curvature at the line and stays positive.
  const PhState<S> lo = table.ph_in(p, h, bubble_side ? Region::kLiquid : Region::kTwoPhase);
  PhState<S> hi;
  if (bubble_side && value_of(d) < 0.0) {
    const S s = -w / width_h;
    const S u = s * d / A;
    const S du_dp = u * (dlogw_dp - dA / A) - s * sat.dh_l_dp / A;
    hi.rho = A * (1.0 + u + u * u);
    hi.drho_dh_p = s * (1.0 + 2.0 * u);
    hi.drho_dp_h = dA * (1.0 + u + u * u) + A * (1.0 + 2.0 * u) * du_dp;
  } else {
    hi = table.ph_in(p, h, bubble_side ? Region::kTwoPhase : Region::kVapour);
  }

  const auto m = smooth_detail::soft_min(lo.rho, hi.rho, w);
  out.rho = m.value;
  out.drho_dh = m.da * lo.drho_dh_p + m.db * hi.drho_dh_p;
  out.drho_dp = m.da * lo.drho_dp_h + m.db * hi.drho_dp_h + m.dw * dw_dp;
  return out;
}

}  // namespace hvac_twin::plant::r32
