// Fast R32 properties on (p, h): boundary-fitted bicubic Hermite tables built from the reference
// EOS (r32_eos.hpp) once, on first use, and read-only afterwards.
//
// Units: SI, mass-based: p [Pa], h [J/kg], T [K], rho [kg/m^3]; derivatives in the matching SI
// units (drho/dp|h [kg/(m^3 Pa)], drho/dh|p [kg^2/(m^3 J)], dT/dp|h [K/Pa], dT/dh|p [K kg/J]).
//
// Layout. The (ln p, h) plane is cut along the saturation curve into three regions:
//   liquid    h_min(p) <= h < h_l(p)     h_min(p) = h(p, kTmin)   (subcooled liquid)
//   two-phase h_l(p) <= h <= h_v(p)      lever rule on saturation curves of p
//   vapour    h_v(p) < h <= h_max(p)     h_max(p) = h(p, kTmax)   (superheated vapour)
// Each single-phase region has its own table on the coordinates eta = ln p and
// xi = (h - h_lower(p)) / (h_upper(p) - h_lower(p)) in [0, 1], so the phase boundary is a grid
// line (xi = 1 of the liquid table, xi = 0 of the vapour table) and no cell straddles it. T and
// ln(rho) are bicubic Hermite patches with node values and eta-, xi- and cross-derivatives from
// the EOS; the boundary curves h_l, h_v, T_sat, ln rho_l, ln rho_v, h_min, h_max are cubic
// Hermite curves in eta on the same pressure nodes with exact EOS slopes. The liquid table's
// xi = 1 edge uses exactly the T_sat and ln rho_l curve data, so T and rho are continuous across
// the bubble and dew lines; their derivatives jump there as they physically do (drho/dh|p by
// 10-60x). Inside each region the interpolant is C1 in (p, h).
//
// Derivatives and AD: evaluation is a template on the scalar type S (double or Dual<K>). With
// S = Dual<K>, every output carries the exact derivative of the interpolant with respect to the
// seeds of p and h, including the partial-derivative outputs (whose tangents are second
// derivatives of the interpolant), consistent with the values. Dual<K> inputs take the fused
// path (r32_table_jet.hpp): the table is evaluated once in double with first and second partial
// derivatives in (p, h), and each output's K tangents are built from them by the chain rule;
// the results equal the operation-by-operation evaluation in Dual<K> (ph_by_operations, kept as
// the reference for tests, and the path of any other scalar type) to rounding. Only where a
// rounding difference moves a point across a table cell border (the interpolant is C1, its
// second derivatives jump there) can the tangents of the partial-derivative outputs differ.
//
// Errors: no exceptions, no allocation. p outside [kPmin, kPmax] or h outside
// [h_min(p), h_max(p)] returns Status::kOutOfRange (> 0, recoverable) with the result evaluated
// at the clamped input (finite; its tangents with respect to the clamped variable are zero).
//
// Thread-safety: ph_table() builds the table on its first call (C++ "magic static": thread-safe,
// about 0.1 s, see README.md); call it once at start-up so no cycle pays for it. All evaluation
// functions are const, reentrant and may be called concurrently from any thread.
#pragma once

#include <array>
#include <cmath>
#include <cstddef>

#include "plant_models/core/dual.hpp"
#include "plant_models/refrigerant/r32_table_jet.hpp"
#include "plant_models/refrigerant/status.hpp"

namespace hvac_twin::plant::r32 {

enum class Region : int { kLiquid = 0, kTwoPhase = 1, kVapour = 2 };

// Result of a (p, h) evaluation.
template <class S>
struct PhState {
  Status status = Status::kOk;
  Region region = Region::kLiquid;
  S T{};          // K
  S rho{};        // kg/m^3
  S quality{};    // (h - h_l)/(h_v - h_l): vapour fraction in two phase, < 0 liquid, > 1 vapour
  S drho_dp_h{};  // kg/(m^3 Pa)
  S drho_dh_p{};  // kg^2/(m^3 J)
  S dT_dp_h{};    // K/Pa
  S dT_dh_p{};    // K kg/J   (0 in two phase)
  S h_l{};        // J/kg, bubble-line enthalpy at p
  S h_v{};        // J/kg, dew-line enthalpy at p
};

// Saturation properties as functions of p, with their derivatives along the saturation curve.
template <class S>
struct SatState {
  Status status = Status::kOk;
  S T{};          // K, saturation temperature
  S h_l{};        // J/kg, bubble-line enthalpy
  S h_v{};        // J/kg, dew-line enthalpy
  S rho_l{};      // kg/m^3
  S rho_v{};      // kg/m^3
  S dT_dp{};      // K/Pa
  S dh_l_dp{};    // J/(kg Pa)
  S dh_v_dp{};    // J/(kg Pa)
  S drho_l_dp{};  // kg/(m^3 Pa)
  S drho_v_dp{};  // kg/(m^3 Pa)
};

namespace table_detail {

inline constexpr int kNp1 = 40;  // pressure nodes uniform in ln p from kPmin to kPsplit
inline constexpr int kNp2 = 25;  // pressure nodes uniform in -ln(pc - p) from kPsplit to kPmax
inline constexpr int kNp = kNp1 + kNp2 - 1;
inline constexpr int kNxL = 24;  // liquid xi nodes (clustered towards the bubble line)
inline constexpr int kNxV = 24;  // vapour xi nodes (clustered towards the dew line)

// A cubic Hermite curve in eta: value and d/deta at each pressure node.
struct Curve {
  std::array<double, kNp> f{};
  std::array<double, kNp> f_e{};
};

// One table node: value, d/deta, d/dxi, d2/(deta dxi) of T and of ln(rho).
struct Node {
  std::array<double, 4> T{};
  std::array<double, 4> L{};
};

// Index i of the interval [x[i], x[i+1]] of the n sorted nodes x holding v (clamped to the
// first/last interval).
inline int find_interval(const double* x, int n, double v) {
  int lo = 0;
  int hi = n - 1;
  while (hi - lo > 1) {
    const int mid = (lo + hi) / 2;
    if (v < x[mid]) {
      hi = mid;
    } else {
      lo = mid;
    }
  }
  return lo;
}

// Hermite basis on [0, 1] and its derivative, evaluated once per coordinate.
template <class S>
struct Basis {
  S h01, h10, h11;  // h00 = 1 - h01
  S d01, d10, d11;  // derivatives with respect to the local coordinate; d00 = -d01
  explicit Basis(const S& a) {
    const S a2 = a * a;
    const S a3 = a2 * a;
    h01 = 3.0 * a2 - 2.0 * a3;
    h10 = a3 - 2.0 * a2 + a;
    h11 = a3 - a2;
    d01 = 6.0 * a - 6.0 * a2;
    d10 = 3.0 * a2 - 4.0 * a + 1.0;
    d11 = 3.0 * a2 - 2.0 * a;
  }
};

// Cubic Hermite on one interval: value and d/deta from node values (f0, f1) and slopes
// (g0, g1) with respect to eta; de is the interval length, B the basis at the local coordinate.
template <class S>
inline void hermite(double f0, double f1, double g0, double g1, double de, const Basis<S>& B,
                    S& value, S& slope) {
  value = f0 + (f1 - f0) * B.h01 + de * g0 * B.h10 + de * g1 * B.h11;
  slope = ((f1 - f0) * B.d01 + de * g0 * B.d10 + de * g1 * B.d11) / de;
}

template <class S>
inline void curve_at(const Curve& c, int i, double de, const Basis<S>& B, S& value, S& slope) {
  const auto k = static_cast<std::size_t>(i);
  hermite(c.f[k], c.f[k + 1], c.f_e[k], c.f_e[k + 1], de, B, value, slope);
}

// Bicubic Hermite patch of one quantity from its 4 corner nodes n[eta corner][xi corner]:
// value f and derivatives f_e = df/deta, f_x = df/dxi.
template <class S>
inline void patch(const std::array<double, 4>* n00, const std::array<double, 4>* n01,
                  const std::array<double, 4>* n10, const std::array<double, 4>* n11, double de,
                  double dx, const Basis<S>& A, const Basis<S>& B, S& f, S& f_e, S& f_x) {
  // Along xi on each eta edge k: g (value), q (d/deta), and their d/dxi.
  const std::array<double, 4>* lo[2] = {n00, n10};
  const std::array<double, 4>* hi[2] = {n01, n11};
  S g[2], gb[2], q[2], qb[2];
  for (int k = 0; k < 2; ++k) {
    const std::array<double, 4>& a = *lo[k];
    const std::array<double, 4>& b = *hi[k];
    g[k] = a[0] + (b[0] - a[0]) * B.h01 + dx * a[2] * B.h10 + dx * b[2] * B.h11;
    gb[k] = (b[0] - a[0]) * B.d01 + dx * a[2] * B.d10 + dx * b[2] * B.d11;
    q[k] = a[1] + (b[1] - a[1]) * B.h01 + dx * a[3] * B.h10 + dx * b[3] * B.h11;
    qb[k] = (b[1] - a[1]) * B.d01 + dx * a[3] * B.d10 + dx * b[3] * B.d11;
  }
  f = g[0] + (g[1] - g[0]) * A.h01 + de * (q[0] * A.h10 + q[1] * A.h11);
  f_e = ((g[1] - g[0]) * A.d01 + de * (q[0] * A.d10 + q[1] * A.d11)) / de;
  f_x = (gb[0] + (gb[1] - gb[0]) * A.h01 + de * (qb[0] * A.h10 + qb[1] * A.h11)) / dx;
}

}  // namespace table_detail

class PhTable {
 public:
  // Coverage. kPmax stays 0.18 MPa below the critical pressure (T_sat = 349.5 K).
  static constexpr double kPmin = 0.05e6;   // Pa  (T_sat = 207.6 K)
  static constexpr double kPmax = 5.6e6;    // Pa
  static constexpr double kPsplit = 3.0e6;  // Pa, where the pressure grid starts to tighten
  static constexpr double kTmin = 200.0;    // K, lower edge of the liquid table (-73 degC)
  static constexpr double kTmax = 435.0;    // K, upper edge of the vapour table (EOS limit)

  PhTable(const PhTable&) = delete;
  PhTable& operator=(const PhTable&) = delete;

  // Properties at (p, h). S = double or Dual<K>.
  template <class S>
  PhState<S> ph(const S& p, const S& h) const;

  // The formula of one region at (p, h), whatever region h is in: the single-phase tables are
  // extrapolated past the saturation line (cubically, from their last cell) and the two-phase
  // lever rule is continued to x < 0 or x > 1. For smoothing across a phase boundary only, a
  // few kJ/kg beyond it; the status reports p out of range, never h.
  template <class S>
  PhState<S> ph_in(const S& p, const S& h, Region region) const;

  // Saturation properties at p (kPmin <= p <= kPmax).
  template <class S>
  SatState<S> sat_p(const S& p) const;

  // The same three, every operation differentiated by its own rule (for S = Dual<K>, what the
  // functions above did before the fused path; the reference the tests compare it with).
  template <class S>
  PhState<S> ph_by_operations(const S& p, const S& h) const;
  template <class S>
  PhState<S> ph_in_by_operations(const S& p, const S& h, Region region) const;
  template <class S>
  SatState<S> sat_p_by_operations(const S& p) const;

  // Enthalpy limits of the tables at p [J/kg] (clamped to the pressure range).
  double h_min(double p) const;
  double h_max(double p) const;

  // kOk when every EOS solve of the build converged (checked by the tests).
  Status build_status() const { return build_status_; }
  // Bytes of table data (the object is a static; nothing is allocated).
  static constexpr std::size_t memory_bytes() { return sizeof(PhTable); }

  // Grid, for tests and benchmarks (e.g. to validate off the nodes).
  double eta_node(int i) const { return eta_[static_cast<std::size_t>(i)]; }
  double xi_liquid_node(int j) const { return xi_l_[static_cast<std::size_t>(j)]; }
  double xi_vapour_node(int j) const { return xi_v_[static_cast<std::size_t>(j)]; }

 private:
  friend const PhTable& ph_table();
  PhTable();  // builds from the EOS (r32_table_build.cpp)

  // The pressure interval holding p (clamped into range, status kOutOfRange if it was not) and
  // the local coordinate a in [0, 1] of ln p within it.
  template <class S>
  struct Located {
    Status status = Status::kOk;
    S p{};
    int i = 0;
    double de = 1.0;
    S a{};
  };
  template <class S>
  Located<S> locate(const S& p) const;
  template <class S>
  void eval_region(const Located<S>& at, const table_detail::Basis<S>& A, const S& h, const S& hl,
                   const S& hl_e, const S& hv, const S& hv_e, Region region, PhState<S>& out) const;

  // The fused path (r32_table_jet.cpp, r32_table_fused.hpp): outputs as Jets in (p, h) at the
  // point evaluated (the clamped one). p_fixed: p was clamped into range (its tangents do not
  // propagate); h_fixed: h was replaced by a boundary curve of p, of slope dh_dp (h's tangents
  // are then dh_dp times p's); empty: nothing evaluated.
  struct JetPh {
    Status status = Status::kOk;
    Region region = Region::kLiquid;
    bool p_fixed = false, h_fixed = false, empty = false;
    double dh_dp = 0.0;
    table_detail::Jet T, rho, quality, h_l, h_v;
  };
  struct JetSat {
    Status status = Status::kOk;
    bool p_fixed = false, empty = false;
    table_detail::Jet T, h_l, h_v, rho_l, rho_v;
  };
  struct JetAt {  // Located, for the fused path
    Status status = Status::kOk;
    bool p_fixed = false;
    int i = 0;
    double de = 1.0;
    table_detail::Jet a;
  };
  JetAt locate_jet(double p) const;
  table_detail::Jet curve_jet(const table_detail::Curve& c, const JetAt& at,
                              const table_detail::Basis2& A) const;
  void single_jet(const table_detail::Node* nodes, const double* xi_nodes, int nx, const JetAt& at,
                  const table_detail::Basis2& A, const table_detail::Jet& h,
                  const table_detail::Jet& lo, const table_detail::Jet& hi, JetPh& out) const;
  void region_jet(const JetAt& at, const table_detail::Basis2& A, const table_detail::Jet& h,
                  const table_detail::Jet& hl, const table_detail::Jet& hv, Region region,
                  JetPh& out) const;
  JetPh ph_jet(double p, double h) const;
  JetPh ph_in_jet(double p, double h, Region region) const;
  JetSat sat_p_jet(double p) const;

  Status build_status_ = Status::kNotConverged;
  std::array<double, table_detail::kNp> eta_{};  // ln p at the pressure nodes
  std::array<double, table_detail::kNxL> xi_l_{};
  std::array<double, table_detail::kNxV> xi_v_{};
  table_detail::Curve t_sat_, ln_rho_l_, ln_rho_v_, h_l_, h_v_, h_min_, h_max_;
  std::array<table_detail::Node, table_detail::kNp * table_detail::kNxL> liquid_{};
  std::array<table_detail::Node, table_detail::kNp * table_detail::kNxV> vapour_{};
};

// The process-wide table, built from the EOS on the first call (thread-safe), then read-only.
const PhTable& ph_table();

// Convenience wrappers on ph_table().
template <class S>
PhState<S> ph_props(const S& p, const S& h) {
  return ph_table().ph(p, h);
}
template <class S>
SatState<S> sat_props(const S& p) {
  return ph_table().sat_p(p);
}

}  // namespace hvac_twin::plant::r32

#include "plant_models/refrigerant/r32_table_eval.hpp"
#include "plant_models/refrigerant/r32_table_fused.hpp"
