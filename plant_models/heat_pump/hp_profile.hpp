// The refrigerant profile inside one heat-exchanger cell, reconstructed from the cell's inlet and
// outlet states, and the means over it that the cell balances need: the mean density (the cell's
// refrigerant mass), and the means of the heat-transfer coefficient alpha and of alpha T (the
// heat from the cell's wall). See plant_models/README.md, "Cell profiles", for the derivation.
//
// In steady flow through a coil whose wall is in local balance with the air, the refrigerant
// enthalpy changes along the tube as dh/ds ~ U(h) (T_air - T(h)), with U the series conductance
// of the refrigerant film and the air side. The share of the cell's length that refrigerant of
// enthalpy h occupies is therefore proportional to g(h) = 1 / (U(h) |T(h) - T_air|), whatever the
// flow: the position weight. A mean over the cell is the g-weighted mean over the enthalpies from
// the outlet state to the inlet state. With these means, a cell's steady outlet state equals the
// continuous model's at the cell boundary for single-phase refrigerant with constant properties
// (it is the log-mean temperature difference), in two-phase flow, and across a phase change
// inside the cell, so the answers hardly depend on the cell count.
//
// The enthalpy range [h_out, h_in] is cut at the bubble and dew enthalpies into up to three
// pieces (liquid, two-phase, vapour). In a single-phase piece T and the specific volume are linear
// in h between the piece's ends; in the two-phase piece T is the saturation temperature and the
// density follows the void-fraction closure. Two ways to integrate a piece:
//   closed form (the filter's model): alpha constant per piece (the enthalpy mean of the
//     blend below), exact integrals of the linear profiles; the two-phase density is
//     rho_l - (rho_l - rho_v) alpha_void(x) with a slip-ratio void fraction
//     alpha_void = x / (x + (1 - x) c), c = (rho_v / rho_l)^e (e = 1: homogeneous, 2/3: Zivi),
//     whose mean over a quality interval is closed-form;
//   quadrature (the reference and benchmark truth): Gauss-Legendre nodes, so alpha may vary with
//     quality (condensing and boiling correlations) and the void fraction may be any closure
//     (Smith's separated-flow slip).
// The single-phase alpha is blended towards the two-phase value near each saturation line:
//     alpha(h) = alpha_1 + (alpha_tp - alpha_1) exp(-|h - h_line| / blend_h),
// continuous, so the means are C1 in the cell's states (the pieces appear and vanish with zero
// length as an end crosses a line).
//
// Units SI: J/kg, K, m^3/kg, W/(m^2 K), W/K. Templated on the scalar R (double, Dual<K>, or
// Tangent<N, S> when the partial derivatives of the means are wanted as values). No allocation,
// no exceptions; thread-safe.
#pragma once

#include <array>
#include <cmath>

#include "plant_models/core/dual.hpp"

namespace hvac_twin::plant::hp {

// The share of a cell's transient enthalpy storage that follows its profile; the rest is lumped
// at the outlet state. All of it on the profile (a centred, "box" storage) leaves the odd-even
// mode of the cell chain undamped where the profile is linear (two-phase cells); all of it at
// the outlet (upwind storage) lets a moving phase boundary expel mass faster than the energy
// balance allows and destabilises the pressure; half and half damps both (see README). The
// storage does not enter any steady state.
inline constexpr double kProfileStorage = 0.5;

// Two-phase closures (model parameters, integer-coded).
enum class VoidFraction : int { kHomogeneous = 0, kZivi = 1, kSmith = 2 };
enum class TwoPhaseHtc : int { kConstant = 0, kCondensing = 1, kBoiling = 2 };

struct ProfileOptions {
  double alpha_liquid = 1500.0;     // W/(m^2 K)
  double alpha_two_phase = 3000.0;  // W/(m^2 K): the constant value, or the correlation's scale
  double alpha_vapour = 800.0;      // W/(m^2 K)
  double area = 0.07;               // m^2, the cell's refrigerant-side area
  double blend_h = 10e3;            // J/kg, width of the alpha blend at the lines
  double dryout_quality = 0.8;      // 1, boiling: dryout begins (correlations only)
  bool alternative_htc = false;     // the benchmark truth's variant of the correlations
  double eps_dt = 0.3;              // K, regularises T - T_air where it vanishes or changes sign
  double line_blend = 1000.0;       // J/kg, where a piece's end moves smoothly off a line
  double heat_sign = 1.0;           // +1: refrigerant warmer than the air (condenser), -1 colder
  VoidFraction void_fraction = VoidFraction::kZivi;
  TwoPhaseHtc htc = TwoPhaseHtc::kConstant;
  bool quadrature = false;  // integrate by Gauss-Legendre nodes (required by kSmith, htc != 0)
};

// The compact smooth max(z, 0) of width w: 0 for z <= -w, z for z >= w, C2 in between (the
// integral of a quintic smoothstep), and its slope (the smoothstep).
template <class R>
R smooth_max0(const R& z, double w) {
  if (value_of(z) <= -w) return R(0.0);
  if (value_of(z) >= w) return z;
  const R t = (z + w) / (2.0 * w);
  const R t4 = t * t * t * t;
  return 2.0 * w * t4 * (2.5 + t * (-3.0 + t));
}
template <class R>
R smooth_max0_slope(const R& z, double w) {
  if (value_of(z) <= -w) return R(0.0);
  if (value_of(z) >= w) return R(1.0);
  const R t = (z + w) / (2.0 * w);
  return t * t * t * (10.0 + t * (-15.0 + 6.0 * t));
}

// Where a single-phase piece of the profile ends, for a cell end of enthalpy h: the vapour piece
// at V(h) = h_v + smax(h - h_v), the liquid piece at L(h) = h_l - smax(h_l - h) (smax of width
// line_blend). Far beyond the line that is h itself, far before it the line; within line_blend
// of the line it moves smoothly, so that a piece never switches from ending at the line to
// ending at a moving end (the slopes of the means would jump). What the piece needs there:
enum class Anchor {
  kOwn,         // h itself: the end's own state
  kLine,        // the saturation line
  kBranchNear,  // V(h) or L(h) just beyond the line: the single-phase branch evaluated there
};
template <class R>
Anchor vapour_anchor(const R& h, const R& h_v, double w) {
  const double z = value_of(h) - value_of(h_v);
  return z >= w ? Anchor::kOwn : z <= -w ? Anchor::kLine : Anchor::kBranchNear;
}
template <class R>
Anchor liquid_anchor(const R& h, const R& h_l, double w) {
  const double z = value_of(h_l) - value_of(h);
  return z >= w ? Anchor::kOwn : z <= -w ? Anchor::kLine : Anchor::kBranchNear;
}

// One cell's ends and saturation data, all at the cell's pressure. For each end, the state where
// the vapour piece ends (at V(h)) and where the liquid piece ends (at L(h)).
template <class R>
struct CellEnds {
  R h_in{}, h_out{};                           // J/kg, inlet (upstream state) and outlet (the cell)
  R T_in_v{}, v_in_v{}, T_out_v{}, v_out_v{};  // K, m^3/kg on the vapour branch at V(h)
  R T_in_l{}, v_in_l{}, T_out_l{}, v_out_l{};  // K, m^3/kg on the liquid branch at L(h)
  R T_sat{}, h_l{}, h_v{}, v_l{}, v_v{};       // saturation at the cell pressure
  R T_air{};                                   // K, air entering the coil
};

// The model-scalar closures of one cell (they may be states): its air-side conductance [W/K],
// the factor on its two-phase heat transfer coefficient, the void-fraction slip exponent.
template <class G>
struct CellScalars {
  G g_air{};
  G alpha_factor{1.0};
  G void_exponent{2.0 / 3.0};
};

template <class R>
struct CellMeans {
  R rho{};      // kg/m^3, mean density: the cell's mass is V rho
  R rho_h{};    // J/m^3, mean of rho h: the cell's enthalpy content is V rho_h
  R alpha{};    // W/(m^2 K), mean of alpha
  R alpha_T{};  // W/(m^2 K) K, mean of alpha T; heat into the refrigerant = A (alpha Tw - alpha_T)
};

namespace profile_detail {

// E(a) = (e^a - 1)/a and F(a) = (e^a - 1 - a)/a^2, smooth through a = 0.
template <class R>
R rel_expm1(const R& a) {
  using std::expm1;
  if (std::abs(value_of(a)) < 1e-4) return 1.0 + a * (0.5 + a * (1.0 / 6.0 + a * (1.0 / 24.0)));
  return expm1(a) / a;
}
template <class R>
R rel_expm1_2(const R& a) {
  using std::expm1;
  if (std::abs(value_of(a)) < 1e-2)
    return 0.5 + a * (1.0 / 6.0 + a * (1.0 / 24.0 + a * (1.0 / 120.0 + a * (1.0 / 720.0))));
  return (expm1(a) - a) / (a * a);
}

// The integrals of one piece over t in [0, 1] (t runs along the piece's enthalpy range), all
// per unit of the piece's enthalpy span: g, rho g, alpha g, alpha T g.
template <class R>
struct PieceIntegrals {
  R g{}, rho{}, rho_h{}, alpha{}, alpha_T{};
};

inline constexpr std::array<double, 4> kGaussNodes{0.0694318442029737, 0.3300094782075719,
                                                   0.6699905217924281, 0.9305681557970263};
inline constexpr std::array<double, 4> kGaussWeights{0.1739274225337269, 0.3260725774662731,
                                                     0.3260725774662731, 0.1739274225337269};

// Conductance refrigerant -> air per unit of alpha-area (film and air side in series), W/K.
template <class R, class G>
R series_conductance(const R& alpha, double area, const G& g_air) {
  return alpha * area * g_air / (alpha * area + g_air);
}

// Enthalpy mean of exp(-d / w) over d in [d1, d2] (either order).
template <class R>
R mean_decay(const R& d1, const R& d2, double w) {
  using std::exp;
  return exp(-d1 / w) * rel_expm1(R(-(d2 - d1) / w));
}

// Void fraction of the quadrature closures; e the slip family's exponent (Zivi 2/3).
template <class R, class E>
R void_fraction(VoidFraction model, const R& x, const R& rho_ratio /* rho_v / rho_l */,
                const E& e) {
  using std::pow;
  using std::sqrt;
  if (value_of(x) <= 0.0) return R(0.0);
  if (value_of(x) >= 1.0) return R(1.0);
  const R y = (1.0 - x) / x;
  if (model == VoidFraction::kSmith) {
    // Smith (1969), entrained-fraction K = 0.4: slip from the homogeneous core.
    constexpr double k = 0.4;
    const R slip = k + (1.0 - k) * sqrt((1.0 / rho_ratio + k * y) / (1.0 + k * y));
    return 1.0 / (1.0 + y * rho_ratio * slip);
  }
  using std::exp;
  using std::log;
  if (model == VoidFraction::kHomogeneous) return 1.0 / (1.0 + y * rho_ratio);
  return 1.0 / (1.0 + y * exp(R(e) * log(rho_ratio)));
}

// Two-phase alpha of the quadrature closures at quality x.
template <class R>
R two_phase_alpha(const ProfileOptions& o, const R& x) {
  using std::exp;
  using std::log;
  const double a = o.alpha_two_phase;
  if (o.htc == TwoPhaseHtc::kCondensing) {
    // Film condensation: highest at the dew line, falling towards the liquid value as the film
    // thickens (shape of Shah's correlation; mean over x close to alpha_two_phase).
    // The variant: linear in x (a thin-film model without the shear term).
    if (o.alternative_htc) return o.alpha_liquid + (1.25 * a - o.alpha_liquid) * x;
    const R xp = value_of(x) > 1e-12 ? exp(0.75 * log(x)) : R(0.0);
    return o.alpha_liquid + (1.35 * a - o.alpha_liquid) * xp;
  }
  if (o.htc == TwoPhaseHtc::kBoiling) {
    // Flow boiling rising with quality (convective), with dryout from x = dryout_quality to the
    // vapour value at x = 1 (smoothstep). The variant: nucleate boiling dominant, flatter in x.
    const R rising = o.alternative_htc ? a * (0.8 + 0.4 * x) : a * (0.7 + 0.6 * x);
    const double xd = o.dryout_quality;
    if (value_of(x) <= xd) return rising;
    if (value_of(x) >= 1.0) return R(o.alpha_vapour);
    const R s = (x - xd) / (1.0 - xd);
    const R w = s * s * (3.0 - 2.0 * s);
    return rising * (1.0 - w) + o.alpha_vapour * w;
  }
  return R(a);
}

}  // namespace profile_detail

// The two-phase heat transfer coefficient at a saturation line (x = 0 at the bubble line, 1 at
// the dew line): the value the single-phase blend approaches there, so alpha is continuous.
inline double line_alpha(const ProfileOptions& o, bool dew) {
  if (!o.quadrature) return o.alpha_two_phase;
  return profile_detail::two_phase_alpha(o, dew ? 1.0 : 0.0);
}

// The local heat transfer coefficient of refrigerant of enthalpy h [J/kg] (the law the cell means
// integrate; used for the wall temperature at a coil's ends); k: the two-phase factor.
template <class R, class K>
R local_alpha(const ProfileOptions& o, const R& h, const R& h_l, const R& h_v, const K& k) {
  using std::exp;
  if (value_of(h) > value_of(h_v)) {
    const K line = k * line_alpha(o, true);
    return o.alpha_vapour + (line - o.alpha_vapour) * exp(-(h - h_v) / o.blend_h);
  }
  if (value_of(h) < value_of(h_l)) {
    const K line = k * line_alpha(o, false);
    return o.alpha_liquid + (line - o.alpha_liquid) * exp(-(h_l - h) / o.blend_h);
  }
  if (!o.quadrature) return R(k * o.alpha_two_phase);
  return k * profile_detail::two_phase_alpha(o, R((h - h_l) / (h_v - h_l)));
}

// The means over one cell's profile; `k` the model-scalar closures (G is R or its base scalar).
template <class R, class G>
CellMeans<R> cell_means(const CellEnds<R>& c, const CellScalars<G>& k, const ProfileOptions& o) {
  const G& g_air = k.g_air;
  using namespace profile_detail;
  using std::log;
  using std::sqrt;
  // The temperature difference that drives the steady profile, sign(T - T_air) as in steady
  // operation, smoothly floored: ~ (T - T_air) heat_sign where that is >> eps, eps/2 where it
  // vanishes, and a tenth of eps on the wrong side of the air (where no steady profile goes:
  // start-up transients), so that the weight stays finite and favours the end nearest the air.
  const auto D = [&](const R& T) {
    const R d = o.heat_sign * (T - c.T_air);
    return 0.5 * (d + sqrt(d * d + o.eps_dt * o.eps_dt)) + 0.1 * o.eps_dt;
  };
  // Single-phase piece from (h1, T1, v1) to (h2, T2, v2), alpha blended from alpha_1 towards the
  // two-phase value with distance from the line h_line.
  const auto single = [&](const R& h1, const R& T1, const R& v1, const R& h2, const R& T2,
                          const R& v2, double alpha_1, const R& h_line, double side) {
    PieceIntegrals<R> p;
    const R D1 = D(T1), D2 = D(T2);
    const R a = log(D2 / D1);
    const R inv_dE = 1.0 / (D1 * rel_expm1(a));  // integral of 1/D over t
    const G tp = k.alpha_factor * line_alpha(o, side > 0.0);
    if (!o.quadrature) {
      const R alpha = alpha_1 + R(tp - alpha_1) * mean_decay(R(side * (h1 - h_line)),
                                                             R(side * (h2 - h_line)), o.blend_h);
      const R inv_u = 1.0 / series_conductance(alpha, o.area, g_air);
      const R b = log(v2 / v1);
      using std::exp;
      p.g = inv_u * inv_dE;
      p.rho = inv_u * exp(-b) / (v1 * D1 * rel_expm1(R(a - b)));
      p.alpha = alpha * p.g;
      // Integrals of T/D and h/D over t, both linear in t: n1 J + (n2 - n1) F(a) J^2 D1.
      const R slope = rel_expm1_2(a) * inv_dE * inv_dE * D1;
      p.alpha_T = alpha * inv_u * (T1 * inv_dE + (T2 - T1) * slope);
      // The enthalpy content: the piece's mean density times its mean enthalpy (rho varies
      // little in one phase; this content only sets the transient capacity, see README).
      p.rho_h = (p.rho / p.g) * inv_u * (h1 * inv_dE + (h2 - h1) * slope);
      return p;
    }
    // Nodes uniform in ln D, where the weight 1/D is flat: with t = (e^(a u) - 1)/(e^a - 1),
    // the integral of X/D over t is inv_dE times the integral of X over u in [0, 1].
    using std::exp;
    for (std::size_t j = 0; j < kGaussNodes.size(); ++j) {
      const double u = kGaussNodes[j];
      const R t = rel_expm1(R(a * u)) * u / rel_expm1(a);
      const R h = h1 + (h2 - h1) * t;
      const R T = T1 + (T2 - T1) * t;
      const R v = v1 + (v2 - v1) * t;
      const R alpha = alpha_1 + R(tp - alpha_1) * exp(-side * (h - h_line) / o.blend_h);
      const R w = kGaussWeights[j] * inv_dE / series_conductance(alpha, o.area, g_air);
      p.g += w;
      p.rho += w / v;
      p.rho_h += w * h / v;
      p.alpha += w * alpha;
      p.alpha_T += w * alpha * T;
    }
    return p;
  };
  const auto two_phase = [&](const R& h1, const R& h2) {
    PieceIntegrals<R> p;
    const R hfg = c.h_v - c.h_l;
    const R x1 = (h1 - c.h_l) / hfg, x2 = (h2 - c.h_l) / hfg;
    const R rho_l = 1.0 / c.v_l, rho_v = 1.0 / c.v_v;
    const R inv_d = 1.0 / D(c.T_sat);
    if (!o.quadrature) {
      const G e = o.void_fraction == VoidFraction::kHomogeneous ? G(1.0) : k.void_exponent;
      using std::exp;
      const R cc = exp(R(e) * log(c.v_l / c.v_v));  // (rho_v / rho_l)^e
      const R bb = 1.0 - cc;
      const R u1 = cc + bb * x1, u2 = cc + bb * x2;
      const R mean_void = (1.0 - cc / (u1 * rel_expm1(R(log(u2 / u1))))) / bb;
      // Mean of x alpha_void: x alpha = (x - c alpha) / b.
      const R mean_x = 0.5 * (x1 + x2);
      const R mean_x_void = (mean_x - cc * mean_void) / bb;
      const G alpha_tp = k.alpha_factor * o.alpha_two_phase;
      const R inv_u = 1.0 / series_conductance(R(alpha_tp), o.area, g_air);
      p.g = inv_u * inv_d;
      p.rho = p.g * (rho_l - (rho_l - rho_v) * mean_void);
      p.rho_h = p.g * (rho_l * (c.h_l + hfg * mean_x) -
                       (rho_l - rho_v) * (c.h_l * mean_void + hfg * mean_x_void));
      p.alpha = alpha_tp * p.g;
      p.alpha_T = p.alpha * c.T_sat;
      return p;
    }
    const R ratio = rho_v / rho_l;
    for (std::size_t j = 0; j < kGaussNodes.size(); ++j) {
      const R x = x1 + (x2 - x1) * kGaussNodes[j];
      const R alpha = k.alpha_factor * two_phase_alpha(o, x);
      const R w = kGaussWeights[j] * inv_d / series_conductance(alpha, o.area, g_air);
      const R av = void_fraction(o.void_fraction, x, ratio, k.void_exponent);
      const R rho = rho_l - (rho_l - rho_v) * av;
      p.g += w;
      p.rho += w * rho;
      p.rho_h += w * rho * (c.h_l + hfg * x);
      p.alpha += w * alpha;
      p.alpha_T += w * alpha * c.T_sat;
    }
    return p;
  };

  // The pieces: [V(h_out), V(h_in)] vapour, [L(h_out), L(h_in)] liquid, and between them the
  // two-phase piece [P(h_out), P(h_in)] with P(h) = h - smax(h - h_v) + smax(h_l - h): the
  // spans add up to h_in - h_out, and each is a share in [0, 1] of it (V, P and L are monotone).
  const double w = o.line_blend;
  const auto V = [&](const R& h) { return c.h_v + smooth_max0(R(h - c.h_v), w); };
  const auto L = [&](const R& h) { return c.h_l - smooth_max0(R(c.h_l - h), w); };
  const auto P = [&](const R& h) {
    return h - smooth_max0(R(h - c.h_v), w) + smooth_max0(R(c.h_l - h), w);
  };
  const R span = c.h_in - c.h_out;
  std::array<R, 3> share{};  // vapour, two-phase, liquid
  if (value_of(span) != 0.0) {
    share[0] = (V(c.h_in) - V(c.h_out)) / span;
    share[1] = (P(c.h_in) - P(c.h_out)) / span;
    share[2] = (L(c.h_in) - L(c.h_out)) / span;
  } else {  // a uniform cell: the slopes of V, P, L at its enthalpy
    share[0] = smooth_max0_slope(R(c.h_out - c.h_v), w);
    share[2] = smooth_max0_slope(R(c.h_l - c.h_out), w);
    share[1] = 1.0 - share[0] - share[2];
  }
  PieceIntegrals<R> sum;
  const auto add = [&sum](const R& f, const PieceIntegrals<R>& p) {
    sum.g += f * p.g;
    sum.rho += f * p.rho;
    sum.rho_h += f * p.rho_h;
    sum.alpha += f * p.alpha;
    sum.alpha_T += f * p.alpha_T;
  };
  if (value_of(share[0]) != 0.0)
    add(share[0], single(V(c.h_out), c.T_out_v, c.v_out_v, V(c.h_in), c.T_in_v, c.v_in_v,
                         o.alpha_vapour, c.h_v, 1.0));
  if (value_of(share[1]) != 0.0) add(share[1], two_phase(P(c.h_out), P(c.h_in)));
  if (value_of(share[2]) != 0.0)
    add(share[2], single(L(c.h_out), c.T_out_l, c.v_out_l, L(c.h_in), c.T_in_l, c.v_in_l,
                         o.alpha_liquid, c.h_l, -1.0));
  return {sum.rho / sum.g, sum.rho_h / sum.g, sum.alpha / sum.g, sum.alpha_T / sum.g};
}

}  // namespace hvac_twin::plant::hp
