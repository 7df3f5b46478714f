// The cell-profile means of hp_profile.hpp: the closed forms equal a brute-force integration of
// the same profile, the quadrature path (the truth's) agrees with them on the filter's closures,
// the means are C1 as an end crosses a saturation line, and their partials (Tangent) are exact.
#include <catch2/catch.hpp>
#include <cmath>

#include "plant_models/core/tangent.hpp"
#include "plant_models/heat_pump/hp_profile.hpp"
#include "plant_models/refrigerant/r32_table.hpp"

using namespace hvac_twin::plant;
using namespace hvac_twin::plant::hp;
namespace r32 = hvac_twin::plant::r32;

namespace {

constexpr double kG = 60.0;  // W/K, a cell's air side

ProfileOptions condenser() {
  ProfileOptions o;
  o.alpha_two_phase = 3000.0;
  o.area = 0.07;
  o.heat_sign = 1.0;
  return o;
}

ProfileOptions evaporator() {
  ProfileOptions o = condenser();
  o.alpha_two_phase = 4000.0;
  o.area = 0.039;
  o.heat_sign = -1.0;
  return o;
}

// A cell's ends as the model builds them (heat_pump_eval.hpp, coil_cell), in Tangent<1>: the
// slope in the inlet's enthalpy (move_inlet) or the outlet's.
using Slope = Tangent<1, double>;
CellEnds<Slope> ends_t(double p, double h_in, double h_out, double t_air, bool move_inlet) {
  const auto s = r32::sat_props(p);
  const double w = ProfileOptions{}.line_blend;
  const auto anchor = [&](double h, bool moving, bool vapour, Slope& T, Slope& v) {
    const double k = moving ? 1.0 : 0.0;
    const Anchor kind = vapour ? vapour_anchor(h, s.h_v, w) : liquid_anchor(h, s.h_l, w);
    if (kind == Anchor::kLine) {
      T = Slope(s.T);
      v = Slope(1.0 / (vapour ? s.rho_v : s.rho_l));
      return;
    }
    double e = h, de = 1.0;
    if (kind == Anchor::kBranchNear) {
      const double z = vapour ? h - s.h_v : s.h_l - h;
      e = vapour ? s.h_v + smooth_max0(z, w) : s.h_l - smooth_max0(z, w);
      de = smooth_max0_slope(z, w);
    }
    const auto st =
        kind == Anchor::kOwn
            ? r32::ph_props(p, h)
            : r32::ph_table().ph_in(p, e, vapour ? r32::Region::kVapour : r32::Region::kLiquid);
    T = Slope::seed(st.T, 0, k * st.dT_dh_p * de);
    v = Slope::seed(1.0 / st.rho, 0, -k * st.drho_dh_p * de / (st.rho * st.rho));
  };
  CellEnds<Slope> c;
  c.h_in = Slope::seed(h_in, 0, move_inlet ? 1.0 : 0.0);
  c.h_out = Slope::seed(h_out, 0, move_inlet ? 0.0 : 1.0);
  anchor(h_in, move_inlet, true, c.T_in_v, c.v_in_v);
  anchor(h_in, move_inlet, false, c.T_in_l, c.v_in_l);
  anchor(h_out, !move_inlet, true, c.T_out_v, c.v_out_v);
  anchor(h_out, !move_inlet, false, c.T_out_l, c.v_out_l);
  c.T_sat = Slope(s.T);
  c.h_l = Slope(s.h_l);
  c.h_v = Slope(s.h_v);
  c.v_l = Slope(1.0 / s.rho_l);
  c.v_v = Slope(1.0 / s.rho_v);
  c.T_air = Slope(t_air);
  return c;
}

CellEnds<double> ends(double p, double h_in, double h_out, double t_air) {
  const CellEnds<Slope> t = ends_t(p, h_in, h_out, t_air, true);
  return {t.h_in.v,   t.h_out.v,  t.T_in_v.v,  t.v_in_v.v,  t.T_out_v.v, t.v_out_v.v,
          t.T_in_l.v, t.v_in_l.v, t.T_out_l.v, t.v_out_l.v, t.T_sat.v,   t.h_l.v,
          t.h_v.v,    t.v_l.v,    t.v_v.v,     t.T_air.v};
}

// The same profile integrated by brute force: the enthalpy range cut at the lines, 20000
// midpoint nodes per piece, T and v linear in h within a single-phase piece, the two-phase
// density from the void fraction at each node, the floored driving difference linear within a
// piece, alpha constant per piece (its enthalpy mean).
CellMeans<double> brute(const CellEnds<double>& c, const ProfileOptions& o,
                        bool alpha_per_node = false) {
  const auto D = [&](double T) {
    const double d = o.heat_sign * (T - c.T_air);
    return 0.5 * (d + std::sqrt(d * d + o.eps_dt * o.eps_dt)) + 0.1 * o.eps_dt;
  };
  double g = 0, rho = 0, rho_h = 0, alpha = 0, alpha_t = 0;
  const auto piece = [&](double h1, double T1, double v1, double h2, double T2, double v2,
                         bool two_phase, double alpha_1, double h_line, double side) {
    if (h1 == h2) return;
    constexpr int kNodes = 20000;
    double a_mean = o.alpha_two_phase;
    if (!two_phase) {
      a_mean = 0.0;
      for (int i = 0; i < kNodes; ++i) {
        const double h = h1 + (h2 - h1) * (i + 0.5) / kNodes;
        a_mean +=
            (alpha_1 + (o.alpha_two_phase - alpha_1) * std::exp(-side * (h - h_line) / o.blend_h)) /
            kNodes;
      }
    }
    const double u = a_mean * o.area * kG / (a_mean * o.area + kG);
    const double D1 = D(T1), D2 = D(T2);
    for (int i = 0; i < kNodes; ++i) {
      const double t = (i + 0.5) / kNodes;
      const double h = h1 + (h2 - h1) * t;
      const double T = two_phase ? c.T_sat : T1 + (T2 - T1) * t;
      double r = 1.0 / (v1 + (v2 - v1) * t);
      if (two_phase) {
        const double x = (h - c.h_l) / (c.h_v - c.h_l);
        const double rl = 1.0 / c.v_l, rv = 1.0 / c.v_v;
        r = rl - (rl - rv) * profile_detail::void_fraction(o.void_fraction, x, rv / rl, 2.0 / 3.0);
      }
      double a_here = a_mean, u_here = u;
      if (alpha_per_node && !two_phase) {
        a_here =
            alpha_1 + (o.alpha_two_phase - alpha_1) * std::exp(-side * (h - h_line) / o.blend_h);
        u_here = a_here * o.area * kG / (a_here * o.area + kG);
      }
      const double w = (h2 - h1) / kNodes / (u_here * (D1 + (D2 - D1) * t));
      g += w;
      rho += w * r;
      // The closed form's single-phase content is the piece's mean density times its mean h.
      rho_h += w * (two_phase ? r * h : h);
      alpha += w * a_here;
      alpha_t += w * a_here * T;
    }
  };
  // Pieces as in cell_means, with the single-phase content corrected afterwards.
  const double hv_out = std::max(c.h_out, c.h_v), hv_in = std::max(c.h_in, c.h_v);
  const double hl_out = std::min(c.h_out, c.h_l), hl_in = std::min(c.h_in, c.h_l);
  const double tp_out = std::clamp(c.h_out, c.h_l, c.h_v), tp_in = std::clamp(c.h_in, c.h_l, c.h_v);
  double g_before = 0, rho_before = 0, rhoh_before = 0;
  const auto single_content = [&](auto&& run) {
    g_before = g;
    rho_before = rho;
    rhoh_before = rho_h;
    run();
    const double gp = g - g_before;
    if (gp == 0.0) return;                                                  // no such piece
    rho_h = rhoh_before + (rho - rho_before) / gp * (rho_h - rhoh_before);  // mean rho x int h g
  };
  single_content([&] {
    piece(hv_out, c.T_out_v, c.v_out_v, hv_in, c.T_in_v, c.v_in_v, false, o.alpha_vapour, c.h_v,
          1.0);
  });
  piece(tp_out, c.T_sat, 0, tp_in, c.T_sat, 0, true, 0, 0, 0);
  single_content([&] {
    piece(hl_out, c.T_out_l, c.v_out_l, hl_in, c.T_in_l, c.v_in_l, false, o.alpha_liquid, c.h_l,
          -1.0);
  });
  return {rho / g, rho_h / g, alpha / g, alpha_t / g};
}

void check_close(const CellMeans<double>& a, const CellMeans<double>& b, double tol) {
  CHECK(a.rho == Approx(b.rho).epsilon(tol));
  CHECK(a.rho_h == Approx(b.rho_h).epsilon(tol));
  CHECK(a.alpha == Approx(b.alpha).epsilon(tol));
  CHECK(a.alpha_T == Approx(b.alpha_T).epsilon(tol));
}

}  // namespace

TEST_CASE("closed-form cell means equal a brute-force integration of the same profile",
          "[profile]") {
  const double p = 2.9e6;
  const auto s = r32::sat_props(p);
  const double t_out = 308.15;
  struct Case {
    const char* name;
    double h_in, h_out;
  };
  for (const Case& k : {Case{"desuperheating into two-phase", s.h_v + 80e3, s.h_v - 60e3},
                        Case{"two-phase into subcooled liquid", s.h_l + 40e3, s.h_l - 15e3},
                        Case{"vapour through to liquid", s.h_v + 40e3, s.h_l - 10e3},
                        Case{"vapour only", s.h_v + 90e3, s.h_v + 20e3},
                        Case{"two-phase only", s.h_v - 30e3, s.h_l + 50e3},
                        Case{"liquid only", s.h_l - 5e3, s.h_l - 18e3}}) {
    INFO(k.name);
    for (const VoidFraction v : {VoidFraction::kHomogeneous, VoidFraction::kZivi}) {
      ProfileOptions o = condenser();
      o.void_fraction = v;
      const auto c = ends(p, k.h_in, k.h_out, t_out);
      check_close(cell_means(c, CellScalars<double>{kG}, o), brute(c, o), 1e-6);
    }
  }
  // The evaporator: two-phase into superheated vapour near the air temperature.
  const double pe = 0.98e6;
  const auto se = r32::sat_props(pe);
  const auto c = ends(pe, se.h_v - 40e3, se.h_v + 12e3, 300.15);
  check_close(cell_means(c, CellScalars<double>{kG}, evaporator()), brute(c, evaporator()), 1e-6);
}

TEST_CASE("the quadrature path integrates the profile with alpha varying along it", "[profile]") {
  const double p = 2.9e6;
  const auto s = r32::sat_props(p);
  ProfileOptions closed = condenser();
  ProfileOptions quad = closed;
  quad.quadrature = true;
  for (const auto& [h_in, h_out] : {std::pair{s.h_v + 60e3, s.h_v - 40e3},
                                    {s.h_l + 30e3, s.h_l - 10e3},
                                    {s.h_v - 20e3, s.h_l + 40e3}}) {
    const auto c = ends(p, h_in, h_out, 308.15);
    // Four Gauss nodes per piece (alpha varying within a piece, as the truth's closures make it)
    // against the same profile integrated by brute force.
    check_close(cell_means(c, CellScalars<double>{kG}, quad), brute(c, closed, true), 2e-3);
  }
}

TEST_CASE("the cell means and their slopes are continuous as an end crosses a saturation line",
          "[profile]") {
  const double p = 2.9e6;
  const auto s = r32::sat_props(p);
  const ProfileOptions o = condenser();
  // The means and their slope in the moving end, that end at line -+ delta.
  const auto at = [&](double h_in, double h_out, bool move_outlet) {
    return cell_means(ends_t(p, h_in, h_out, 308.15, !move_outlet), CellScalars<double>{kG}, o);
  };
  struct Crossing {
    const char* name;
    double h_in, h_out;  // the moving end sits on the line
    bool move_outlet;
  };
  for (const Crossing& k : {Crossing{"outlet across the dew line", s.h_v + 60e3, s.h_v, true},
                            Crossing{"outlet across the bubble line", s.h_l + 50e3, s.h_l, true},
                            Crossing{"inlet across the dew line", s.h_v, s.h_l + 20e3, false},
                            Crossing{"inlet across the bubble line", s.h_l, s.h_l - 15e3, false}}) {
    INFO(k.name);
    for (const double at_line : {0.0, 0.5 * o.line_blend}) {  // the line and inside the blend
      const double delta = 1e-3;                              // J/kg
      const auto shifted = [&](double d) {
        return k.move_outlet ? at(k.h_in, k.h_out + at_line + d, true)
                             : at(k.h_in + at_line + d, k.h_out, false);
      };
      const auto below = shifted(-delta), above = shifted(delta);
      // Values move by the slope over 2 delta; slopes agree to 1e-4 (or are negligible: a
      // slope of alpha_T below 1e-5 K W/(m2 K) per J/kg).
      CHECK(below.rho.v == Approx(above.rho.v).epsilon(1e-7));
      CHECK(below.rho.d[0] == Approx(above.rho.d[0]).epsilon(1e-4));
      CHECK(below.rho_h.d[0] == Approx(above.rho_h.d[0]).epsilon(1e-4));
      CHECK(below.alpha_T.d[0] == Approx(above.alpha_T.d[0]).epsilon(1e-4).margin(1e-5));
      CHECK(below.alpha.d[0] == Approx(above.alpha.d[0]).epsilon(1e-4).margin(1e-7));
    }
  }
}

TEST_CASE("the cell means' partials equal central differences", "[profile]") {
  // Ends from the table as functions of (p, h_in, h_out, T_air), seeded as the model seeds them.
  const ProfileOptions o = condenser();
  using T = Tangent<4, double>;
  const auto means = [&](double p, double h_in, double h_out, double t_air) {
    return cell_means(ends(p, h_in, h_out, t_air), CellScalars<double>{kG}, o);
  };
  // Away from the lines (as here) each piece ends at an end's own state or at a line.
  const auto seeded = [&](double p, double h_in, double h_out, double t_air) {
    const auto a = r32::ph_props(p, h_in), b = r32::ph_props(p, h_out);
    const auto s = r32::sat_props(p);
    const auto with = [](double v, std::initializer_list<std::pair<int, double>> d) {
      T t(v);
      for (const auto& [i, x] : d)
        t.d[static_cast<std::size_t>(i)] = x;
      return t;
    };
    const auto own = [&](const r32::PhState<double>& st, int j, T& temp, T& vol) {
      const double v = 1.0 / st.rho;
      temp = with(st.T, {{0, st.dT_dp_h}, {j, st.dT_dh_p}});
      vol = with(v, {{0, -st.drho_dp_h * v * v}, {j, -st.drho_dh_p * v * v}});
    };
    const auto line = [&](bool vapour, T& temp, T& vol) {
      const double rho = vapour ? s.rho_v : s.rho_l, rp = vapour ? s.drho_v_dp : s.drho_l_dp;
      temp = with(s.T, {{0, s.dT_dp}});
      vol = with(1.0 / rho, {{0, -rp / (rho * rho)}});
    };
    CellEnds<T> c;
    c.h_in = T::seed(h_in, 1);
    c.h_out = T::seed(h_out, 2);
    c.T_air = T::seed(t_air, 3);
    own(a, 1, c.T_in_v, c.v_in_v);  // the inlet is vapour
    line(false, c.T_in_l, c.v_in_l);
    line(true, c.T_out_v, c.v_out_v);  // the outlet is two-phase
    line(false, c.T_out_l, c.v_out_l);
    (void)b;
    c.T_sat = with(s.T, {{0, s.dT_dp}});
    c.h_l = with(s.h_l, {{0, s.dh_l_dp}});
    c.h_v = with(s.h_v, {{0, s.dh_v_dp}});
    c.v_l = with(1.0 / s.rho_l, {{0, -s.drho_l_dp / (s.rho_l * s.rho_l)}});
    c.v_v = with(1.0 / s.rho_v, {{0, -s.drho_v_dp / (s.rho_v * s.rho_v)}});
    return cell_means(c, CellScalars<double>{kG}, o);
  };
  const double p = 2.9e6;
  const auto s = r32::sat_props(p);
  const std::array<double, 4> x{p, s.h_v + 50e3, s.h_l + 80e3, 308.15};
  const std::array<double, 4> step{50.0, 5.0, 5.0, 1e-3};
  const auto m = seeded(x[0], x[1], x[2], x[3]);
  for (int i = 0; i < 4; ++i) {
    auto xp = x, xm = x;
    xp[static_cast<std::size_t>(i)] += step[static_cast<std::size_t>(i)];
    xm[static_cast<std::size_t>(i)] -= step[static_cast<std::size_t>(i)];
    const auto fp = means(xp[0], xp[1], xp[2], xp[3]), fm = means(xm[0], xm[1], xm[2], xm[3]);
    const double h = 2.0 * step[static_cast<std::size_t>(i)];
    INFO("direction " << i);
    const auto u = static_cast<std::size_t>(i);
    CHECK(m.rho.d[u] == Approx((fp.rho - fm.rho) / h).epsilon(1e-5).margin(1e-12));
    CHECK(m.rho_h.d[u] == Approx((fp.rho_h - fm.rho_h) / h).epsilon(1e-5).margin(1e-6));
    CHECK(m.alpha_T.d[u] == Approx((fp.alpha_T - fm.alpha_T) / h).epsilon(1e-5).margin(1e-6));
  }
}
