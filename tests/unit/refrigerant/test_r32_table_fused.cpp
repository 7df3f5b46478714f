// The fused Dual<K> evaluation of the (p, h) table (r32_table_jet.hpp) against the
// operation-by-operation evaluation it replaced (ph_by_operations and friends): values and every
// tangent, including those of the partial-derivative outputs (second derivatives), in every
// region, beyond the phase lines (ph_in), on the saturation curves (sat_p), with clamped inputs,
// and with general tangents (not only unit seeds). Also against finite differences.
#include <algorithm>
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "plant_models/core/dual.hpp"
#include "plant_models/refrigerant/r32_table.hpp"

namespace r32 = hvac_twin::plant::r32;
using hvac_twin::plant::Dual;

namespace {

// Two inputs with arbitrary tangents in three directions: p and h each move in two of them,
// at different rates, as inside a model's Jacobian.
struct Inputs {
  Dual<3> p, h;
};
Inputs inputs(double p, double h) {
  Inputs in{Dual<3>(p), Dual<3>(h)};
  in.p.d = {1.0, 0.0, 0.37};
  in.h.d = {0.0, 1.0, -2.9e-2};  // J/kg per Pa
  return in;
}

// The error of a against b, each value and tangent compared with the size of the quantity and
// of its change over the input ranges: |x| + |dx/dp| P + |dx/dh| H (P = p, H the table's
// enthalpy span at p), so that a tangent which is small only because its terms cancel is judged
// on the scale of the terms. Keeps the largest, where it was, and how many outputs exceed 1e-12.
struct Compare {
  double P = 1.0, H = 1.0, h = 0.0;  // the current point
  int output = 0;                    // the current output (for the report)
  double worst = 0.0, at_p = 0.0, at_h = 0.0;
  int at_output = -1;
  long outputs = 0, above_1e12 = 0;

  void operator()(const Dual<3>& a, const Dual<3>& b, const Dual<2>& unit) {
    const double e = error(a, b, unit);
    ++outputs;
    if (e > 1e-12) ++above_1e12;
    if (e > worst) {
      worst = e;
      at_p = P;
      at_h = h;
      at_output = output;
    }
    ++output;
  }
  double error(const Dual<3>& a, const Dual<3>& b, const Dual<2>& unit) const {
    const double scale = std::abs(unit.v) + std::abs(unit.d[0]) * P + std::abs(unit.d[1]) * H;
    if (scale == 0.0) return std::max({std::abs(a.v), std::abs(a.d[0]), std::abs(a.d[1])});
    // Direction k moves p by |p.d[k]| and h by |h.d[k]| per unit: its tangent's scale.
    const std::array<double, 3> per_unit = {1.0 / P, 1.0 / H, 1.0 / P};
    double e = std::abs(a.v - b.v) / scale;
    for (std::size_t k = 0; k < 3; ++k)
      e = std::max(e, std::abs(a.d[k] - b.d[k]) / (scale * per_unit[k]));
    return e;
  }
};

Dual<2> seeded(double v, int k) {
  Dual<2> d(v);
  d.d[static_cast<std::size_t>(k)] = 1.0;
  return d;
}

// Every output of two PhStates (and the unit-seed reference that sets each output's scale); the
// partials at constant h in c_dp, every other output in c.
void compare(const r32::PhState<Dual<3>>& a, const r32::PhState<Dual<3>>& b,
             const r32::PhState<Dual<2>>& u, Compare& c, Compare& c_dp) {
  CHECK(a.status == b.status);
  CHECK(a.region == b.region);
  c(a.T, b.T, u.T);
  c(a.rho, b.rho, u.rho);
  c(a.quality, b.quality, u.quality);
  c(a.drho_dh_p, b.drho_dh_p, u.drho_dh_p);
  c(a.dT_dh_p, b.dT_dh_p, u.dT_dh_p);
  c(a.h_l, b.h_l, u.h_l);
  c(a.h_v, b.h_v, u.h_v);
  c_dp(a.drho_dp_h, b.drho_dp_h, u.drho_dp_h);
  c_dp(a.dT_dp_h, b.dT_dp_h, u.dT_dp_h);
}

std::vector<double> pressures() {
  std::vector<double> p;
  for (double v = 0.0503e6; v < 5.6e6; v *= 1.0613)
    p.push_back(v);
  return p;
}

}  // namespace

TEST_CASE("fused Dual evaluation equals the operation-by-operation one", "[refrigerant][table]") {
  const r32::PhTable& t = r32::ph_table();
  REQUIRE(t.build_status() == r32::Status::kOk);
  Compare c, c_dp, beyond_lines, beyond_lines_dp;
  int points = 0;
  for (const double p : pressures()) {
    const double lo = t.h_min(p), hi = t.h_max(p);
    for (int b = -3; b <= 123; ++b) {  // a little beyond both ends: h clamped there
      const double h = lo + (hi - lo) * (b + 0.137) / 120.0;
      const Inputs in = inputs(p, h);
      const auto u = t.ph_by_operations(seeded(p, 0), seeded(h, 1));
      for (Compare* x : {&c, &c_dp}) {
        x->P = p;
        x->H = hi - lo;
        x->h = h;
        x->output = 0;
      }
      compare(t.ph(in.p, in.h), t.ph_by_operations(in.p, in.h), u, c, c_dp);
      ++points;
    }
    // The formulas meeting at each phase line, up to 5 kJ/kg beyond it (what the smoothing
    // evaluates).
    const auto sat = t.sat_p(p);
    const auto beyond = [&](double line, r32::Region below, r32::Region above) {
      for (const double d : {-5e3, -300.0, 300.0, 5e3}) {
        for (const auto region : {below, above}) {
          const Inputs in = inputs(p, line + d);
          const auto u = t.ph_in_by_operations(seeded(p, 0), seeded(line + d, 1), region);
          for (Compare* x : {&beyond_lines, &beyond_lines_dp}) {
            x->P = p;
            x->H = hi - lo;
            x->h = line + d;
            x->output = 10 * (static_cast<int>(region) + 1);
          }
          compare(t.ph_in(in.p, in.h, region), t.ph_in_by_operations(in.p, in.h, region), u,
                  beyond_lines, beyond_lines_dp);
          ++points;
        }
      }
    };
    beyond(sat.h_l, r32::Region::kLiquid, r32::Region::kTwoPhase);
    beyond(sat.h_v, r32::Region::kTwoPhase, r32::Region::kVapour);
  }
  INFO(points << " points; largest scaled difference " << c.worst << "; of the partials at "
              << "constant h " << c_dp.worst << " at p = " << c_dp.at_p << " Pa, h = " << c_dp.at_h
              << " J/kg, " << c_dp.above_1e12 << " of " << c_dp.outputs << " above 1e-12; beyond "
              << "the phase lines " << beyond_lines.worst << ", " << beyond_lines_dp.worst);
  // Equal to rounding.
  CHECK(c.worst < 1e-12);
  // The partials at constant h (drho/dp|h, dT/dp|h) are sums of terms that nearly cancel (the
  // p-dependence of the table's xi coordinate), and so are their tangents: a few % of them
  // differ by more than 1e-12 of their scale, all by less than 1e-9 in the table, where both
  // evaluations round differently. Example, the largest: at 68 kPa, 0.8 kJ/kg below the bubble
  // line (the liquid table's narrowest cells), the reference's own two mixed partials
  // d(dT/dp)/dh and d(dT/dh)/dp differ by 2.4e-10 relative; the fused one, symmetric by
  // construction, equals the second to 1e-12.
  CHECK(c_dp.worst < 1e-9);
  // Beyond a phase line the table is extrapolated (its cubic far outside its last cell) and the
  // cancellation is stronger, in every output's tangents: there the reference's mixed partials
  // differ by up to 6e-8 (64 kPa, 5 kJ/kg below the bubble line).
  CHECK(beyond_lines.worst < 1e-9);
  CHECK(beyond_lines_dp.worst < 1e-6);
}

TEST_CASE("fused saturation properties equal the operation-by-operation ones",
          "[refrigerant][table]") {
  const r32::PhTable& t = r32::ph_table();
  double worst = 0.0;
  for (const double p : pressures()) {
    Dual<3> pd(p);
    pd.d = {1.0, -0.5, 3.0};
    const auto a = t.sat_p(pd);
    const auto b = t.sat_p_by_operations(pd);
    CHECK(a.status == b.status);
    const auto check = [&](const Dual<3>& x, const Dual<3>& y) {
      const double scale = std::abs(y.v) + std::abs(y.d[0]) * p;  // d[0] is d/dp
      worst = std::max(worst, std::abs(x.v - y.v) / scale);
      for (std::size_t k = 0; k < 3; ++k)
        worst = std::max(worst, std::abs(x.d[k] - y.d[k]) * p / scale);
    };
    check(a.T, b.T);
    check(a.h_l, b.h_l);
    check(a.h_v, b.h_v);
    check(a.rho_l, b.rho_l);
    check(a.rho_v, b.rho_v);
    check(a.dT_dp, b.dT_dp);
    check(a.dh_l_dp, b.dh_l_dp);
    check(a.dh_v_dp, b.dh_v_dp);
    check(a.drho_l_dp, b.drho_l_dp);
    check(a.drho_v_dp, b.drho_v_dp);
  }
  INFO("largest scaled difference " << worst);
  CHECK(worst < 1e-12);
}

TEST_CASE("fused evaluation with inputs out of range: clamped like the reference",
          "[refrigerant][table]") {
  const r32::PhTable& t = r32::ph_table();
  const double nan = std::nan("");
  const double cases[][2] = {{1e4, 4e5},
                             {7e6, 4e5},
                             {1e6, t.h_min(1e6) - 1e3},
                             {1e6, t.h_max(1e6) + 1e3},
                             {7e6, t.h_max(5.6e6) + 1e4},
                             {nan, 4e5},
                             {1e6, nan}};
  for (const auto& x : cases) {
    const Inputs in = inputs(x[0], x[1]);
    const auto a = t.ph(in.p, in.h);
    const auto b = t.ph_by_operations(in.p, in.h);
    CHECK(a.status == r32::Status::kOutOfRange);
    CHECK(a.status == b.status);
    CHECK(a.region == b.region);
    const auto same = [](const Dual<3>& u, const Dual<3>& v) {
      const double s = std::max({std::abs(v.v), std::abs(u.v), 1e-300});
      CHECK(std::abs(u.v - v.v) <= 1e-12 * s);
      for (std::size_t k = 0; k < 3; ++k)
        CHECK(std::abs(u.d[k] - v.d[k]) <= 1e-9 * (std::abs(v.d[k]) + 1e-12 * s));
    };
    same(a.T, b.T);
    same(a.rho, b.rho);
    same(a.drho_dh_p, b.drho_dh_p);
    same(a.drho_dp_h, b.drho_dp_h);
    same(a.dT_dh_p, b.dT_dh_p);
  }
  // ph_in with a non-finite enthalpy: nothing evaluated, as before.
  const auto e = t.ph_in(Dual<3>(1e6), Dual<3>(nan), r32::Region::kVapour);
  CHECK(e.status == r32::Status::kOutOfRange);
  CHECK(e.rho.v == 0.0);
}

TEST_CASE("fused second derivatives agree with differences of the partial outputs",
          "[refrigerant][table]") {
  const r32::PhTable& t = r32::ph_table();
  for (const double p : {0.31e6, 1.13e6, 2.71e6, 4.6e6}) {
    const double lo = t.h_min(p), hi = t.h_max(p);
    for (const double x : {0.07, 0.33, 0.52, 0.81, 0.97}) {
      const double h = lo + x * (hi - lo);
      const auto d = t.ph(seeded(p, 0), seeded(h, 1));
      const double dp = 1e-6 * p, dh = 1e-6 * (hi - lo);
      const auto pp = t.ph(p + dp, h), pm = t.ph(p - dp, h);
      const auto hp = t.ph(p, h + dh), hm = t.ph(p, h - dh);
      INFO("p = " << p << ", h = " << h);
      if (pp.region == d.region && pm.region == d.region) {
        CHECK((pp.drho_dh_p - pm.drho_dh_p) / (2 * dp) ==
              Approx(d.drho_dh_p.d[0]).epsilon(1e-4).margin(1e-16));
        CHECK((pp.dT_dh_p - pm.dT_dh_p) / (2 * dp) ==
              Approx(d.dT_dh_p.d[0]).epsilon(1e-4).margin(1e-16));
      }
      if (hp.region == d.region && hm.region == d.region) {
        CHECK((hp.drho_dh_p - hm.drho_dh_p) / (2 * dh) ==
              Approx(d.drho_dh_p.d[1]).epsilon(1e-4).margin(1e-16));
        CHECK((hp.dT_dp_h - hm.dT_dp_h) / (2 * dh) ==
              Approx(d.dT_dp_h.d[1]).epsilon(1e-4).margin(1e-18));
      }
    }
  }
}
