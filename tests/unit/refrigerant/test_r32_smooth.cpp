// The density smoothed across the saturation lines: identical to the table away from them, C1
// (continuous drho/dh) across them, monotone, within its stated bound of the raw density, and
// with partials that are the exact derivatives of the smoothed density.
#include <catch2/catch.hpp>
#include <cmath>

#include "plant_models/core/dual.hpp"
#include "plant_models/refrigerant/r32_smooth.hpp"

namespace r32 = hvac_twin::plant::r32;
using hvac_twin::plant::Dual;

namespace {

constexpr double kWidth = r32::kDefaultSmoothingWidth;

double rho_s(double p, double h) {
  return r32::smooth_ph(p, h).rho;
}

struct Line {
  const char* name;
  bool bubble;
};

double line_h(double p, bool bubble) {
  const auto sat = r32::sat_props(p);
  return bubble ? sat.h_l : sat.h_v;
}

}  // namespace

TEST_CASE("smoothed density equals the table away from the saturation lines", "[smooth]") {
  for (double p : {0.8e6, 2.5e6}) {
    const auto sat = r32::sat_props(p);
    for (double h : {sat.h_l - 30e3, 0.5 * (sat.h_l + sat.h_v), sat.h_v + 30e3}) {
      const auto s = r32::smooth_ph(p, h);
      const auto raw = r32::ph_props(p, h);
      CHECK(s.rho == raw.rho);
      CHECK(s.drho_dh == raw.drho_dh_p);
      CHECK(s.drho_dp == raw.drho_dp_h);
    }
  }
}

TEST_CASE("smoothed density is C1 and monotone across bubble and dew lines", "[smooth]") {
  for (double p : {0.3e6, 0.9e6, 2.5e6, 4.0e6}) {
    for (const Line line : {Line{"bubble", true}, Line{"dew", false}}) {
      INFO(line.name << " line at p = " << p);
      const double h0 = line_h(p, line.bubble);
      const double eps = 1e-3;  // J/kg either side of the line
      const auto left = r32::smooth_ph(p, h0 - eps), right = r32::smooth_ph(p, h0 + eps);
      const auto raw_l = r32::ph_props(p, h0 - eps), raw_r = r32::ph_props(p, h0 + eps);
      // The raw slope jumps; the smoothed one does not.
      CHECK(std::abs(raw_r.drho_dh_p - raw_l.drho_dh_p) >
            0.3 * std::abs(raw_l.drho_dh_p + raw_r.drho_dh_p) * 0.5);
      CHECK(right.drho_dh == Approx(left.drho_dh).epsilon(1e-4));
      CHECK(right.drho_dp == Approx(left.drho_dp).epsilon(1e-4));
      // Monotone: density falls with enthalpy all through the band.
      double worst_bound = 0.0;
      for (double d = -15 * kWidth; d <= 15 * kWidth; d += kWidth / 4) {
        const auto s = r32::smooth_ph(p, h0 + d);
        CHECK(s.drho_dh < 0.0);
        const double raw = r32::ph_props(p, h0 + d).rho;
        // Lowered, never raised, and by at most w ln 2 (w: the width in density units).
        const auto sat = r32::sat_props(p);
        const double A = sat.rho_l, B = sat.rho_v, H = sat.h_v - sat.h_l;
        const double w =
            line.bubble ? kWidth * A * (A - B) / (B * H) : kWidth * B * (A - B) / (A * H);
        CHECK(s.rho <= raw + 1e-9 * raw);
        CHECK(raw - s.rho <= w * std::log(2.0) * 1.05);
        worst_bound = std::max(worst_bound, (raw - s.rho) / raw);
      }
      // Bubble line: about 8 % at 0.3 MPa, 2.8 % at 0.9 MPa, 1.1 % at 2.5 MPa; dew line < 0.3 %.
      INFO("largest relative lowering " << worst_bound);
      CHECK(worst_bound < (line.bubble ? (p < 0.5e6 ? 0.1 : 0.035) : 0.003));
    }
  }
}

TEST_CASE("smoothed partials are the exact derivatives of the smoothed density", "[smooth]") {
  for (double p : {0.5e6, 1.0e6, 2.8e6}) {
    for (const Line line : {Line{"bubble", true}, Line{"dew", false}}) {
      const double h0 = line_h(p, line.bubble);
      for (double d : {-3.0, -0.7, 0.0, 0.4, 2.5}) {
        const double h = h0 + d * kWidth;
        INFO(line.name << " p = " << p << ", h - h_line = " << d * kWidth);
        const auto s = r32::smooth_ph(p, h);
        const double dh = 0.5, dp = 20.0;
        const double fd_h = (rho_s(p, h + dh) - rho_s(p, h - dh)) / (2 * dh);
        const double fd_p = (rho_s(p + dp, h) - rho_s(p - dp, h)) / (2 * dp);
        CHECK(s.drho_dh == Approx(fd_h).epsilon(2e-4));
        CHECK(s.drho_dp == Approx(fd_p).epsilon(2e-4));
        // With dual numbers the tangents of rho are the same partials.
        const Dual<2> pd(p, {1.0, 0.0}), hd(h, {0.0, 1.0});
        const auto sd = r32::smooth_ph(pd, hd);
        CHECK(sd.rho.v == Approx(s.rho).epsilon(1e-14));
        CHECK(sd.rho.d[0] == Approx(s.drho_dp).epsilon(1e-10));
        CHECK(sd.rho.d[1] == Approx(s.drho_dh).epsilon(1e-10));
      }
    }
  }
}
