// Construction of the (p, h) tables from the reference EOS (see r32_table.hpp for the layout).
//
// Node data: at each pressure node p_i and relative enthalpy xi_j the EOS flash gives T and
// ln(rho) and, from the EOS Jacobian, their exact derivatives with respect to p and h. These are
// mapped to the table coordinates (eta = ln p, xi) with the exact slopes of the boundary curves.
// The cross derivative d2f/(deta dxi) is a central difference (step 1e-4 in eta) of the exact
// d/dxi, which is accurate to ~1e-8 relative. Runs once, at start-up; allocates nothing.
#include <algorithm>
#include <cmath>

#include "plant_models/refrigerant/r32_eos.hpp"
#include "plant_models/refrigerant/r32_table.hpp"

namespace hvac_twin::plant::r32 {
namespace {

using table_detail::kNp;
using table_detail::kNp1;
using table_detail::kNp2;
using table_detail::kNxL;
using table_detail::kNxV;

constexpr double kEps = 1e-4;          // eta step of the cross-derivative difference
constexpr double kXiClustering = 1.5;  // xi node exponent (nodes crowd towards saturation)
constexpr double kRhoMax = 2000.0;     // kg/m^3, upper density bracket of the liquid branch

// EOS boundary data at one pressure: saturation and the two isotherms closing the tables.
struct Edge {
  Status status = Status::kOk;
  double p = 0.0;
  Saturation sat;
  Properties lo;        // liquid at PhTable::kTmin
  Properties hi;        // vapour at PhTable::kTmax
  double dh_lo_dp = 0;  // dh/dp along the kTmin isotherm
  double dh_hi_dp = 0;  // dh/dp along the kTmax isotherm
};

Status first_error(Status a, Status b) {
  return a != Status::kOk ? a : b;
}

Edge edge_at(double p) {
  Edge e;
  e.p = p;
  e.sat = saturation_p(p);
  const DensityResult dl = density_pt(p, PhTable::kTmin);
  const DensityResult dv = density_pt(p, PhTable::kTmax);
  e.status = first_error(e.sat.status, first_error(dl.status, dv.status));
  e.lo = properties_trho(PhTable::kTmin, dl.rho);
  e.hi = properties_trho(PhTable::kTmax, dv.rho);
  e.dh_lo_dp = e.lo.dh_drho_T / e.lo.dp_drho_T;
  e.dh_hi_dp = e.hi.dh_drho_T / e.hi.dp_drho_T;
  return e;
}

// Lower and upper enthalpy of a region at an edge, with their p-derivatives.
struct Span {
  double a, a_p, b, b_p;
};
Span span(const Edge& e, bool liquid) {
  if (liquid) return {e.lo.h, e.dh_lo_dp, e.sat.liquid.h, e.sat.dh_l_dp};
  return {e.sat.vapour.h, e.sat.dh_v_dp, e.hi.h, e.dh_hi_dp};
}

// EOS state at (p, xi) of a region, with T and ln(rho) and their derivatives in (eta, xi).
struct Point {
  Status status = Status::kOk;
  double T = 0, rho = 0;
  std::array<double, 2> f{}, f_e{}, f_x{};  // [0] = T, [1] = ln rho
};
Point point_at(const Edge& e, bool liquid, double xi, double T_guess, double rho_guess) {
  const Span s = span(e, liquid);
  const double D = s.b - s.a;
  const double h = s.a + xi * D;
  const Bracket b = liquid ? Bracket{kTtriple, e.sat.T, e.sat.liquid.rho, kRhoMax, true}
                           : Bracket{e.sat.T, 1.2 * kTmaxEos, 0.0, e.sat.vapour.rho, false};
  const FlashResult fl = flash_ph_branch(e.p, h, b, T_guess, rho_guess);
  Point pt;
  pt.status = fl.status;
  pt.T = fl.T;
  pt.rho = fl.rho;
  const PhDerivatives d = ph_derivatives(properties_trho(fl.T, fl.rho));
  const double dh_de = e.p * (s.a_p + xi * (s.b_p - s.a_p));  // dh/deta at constant xi
  const std::array<double, 2> f_p = {d.dT_dp_h, d.drho_dp_h / fl.rho};
  const std::array<double, 2> f_h = {d.dT_dh_p, d.drho_dh_p / fl.rho};
  pt.f = {fl.T, std::log(fl.rho)};
  for (std::size_t q = 0; q < 2; ++q) {
    pt.f_e[q] = e.p * f_p[q] + f_h[q] * dh_de;
    pt.f_x[q] = D * f_h[q];
  }
  return pt;
}

}  // namespace

PhTable::PhTable() {
  Status status = Status::kOk;

  // Pressure nodes: uniform in ln p up to kPsplit, then uniform in -ln(pc - p) so that they
  // tighten towards the critical point, where the saturation curves steepen.
  for (int k = 0; k < kNp1; ++k) {
    const double s = static_cast<double>(k) / static_cast<double>(kNp1 - 1);
    eta_[static_cast<std::size_t>(k)] = std::log(kPmin) + s * (std::log(kPsplit) - std::log(kPmin));
  }
  const double u0 = -std::log(kPc - kPsplit);
  const double u1 = -std::log(kPc - kPmax);
  for (int k = 1; k < kNp2; ++k) {
    const double u = u0 + (u1 - u0) * static_cast<double>(k) / static_cast<double>(kNp2 - 1);
    eta_[static_cast<std::size_t>(kNp1 - 1 + k)] = std::log(kPc - std::exp(-u));
  }
  // Relative-enthalpy nodes, crowded towards the saturation line of each region.
  for (int j = 0; j < kNxL; ++j) {
    const double s = static_cast<double>(j) / static_cast<double>(kNxL - 1);
    xi_l_[static_cast<std::size_t>(j)] = 1.0 - std::pow(1.0 - s, kXiClustering);
  }
  for (int j = 0; j < kNxV; ++j) {
    const double s = static_cast<double>(j) / static_cast<double>(kNxV - 1);
    xi_v_[static_cast<std::size_t>(j)] = std::pow(s, kXiClustering);
  }

  for (std::size_t i = 0; i < static_cast<std::size_t>(kNp); ++i) {
    const double p = std::exp(eta_[i]);
    const Edge e = edge_at(p);
    const Edge em = edge_at(p * std::exp(-kEps));
    const Edge ep = edge_at(p * std::exp(kEps));
    status = first_error(status, first_error(e.status, first_error(em.status, ep.status)));
    const Saturation& sat = e.sat;

    t_sat_.f[i] = sat.T;
    t_sat_.f_e[i] = p * sat.dT_dp;
    ln_rho_l_.f[i] = std::log(sat.liquid.rho);
    ln_rho_l_.f_e[i] = p * sat.drho_l_dp / sat.liquid.rho;
    ln_rho_v_.f[i] = std::log(sat.vapour.rho);
    ln_rho_v_.f_e[i] = p * sat.drho_v_dp / sat.vapour.rho;
    h_l_.f[i] = sat.liquid.h;
    h_l_.f_e[i] = p * sat.dh_l_dp;
    h_v_.f[i] = sat.vapour.h;
    h_v_.f_e[i] = p * sat.dh_v_dp;
    h_min_.f[i] = e.lo.h;
    h_min_.f_e[i] = p * e.dh_lo_dp;
    h_max_.f[i] = e.hi.h;
    h_max_.f_e[i] = p * e.dh_hi_dp;

    for (int region = 0; region < 2; ++region) {
      const bool liquid = region == 0;
      const int nx = liquid ? kNxL : kNxV;
      double T_guess = liquid ? kTmin : sat.T;
      double rho_guess = liquid ? e.lo.rho : sat.vapour.rho;
      for (int j = 0; j < nx; ++j) {
        const double xi =
            liquid ? xi_l_[static_cast<std::size_t>(j)] : xi_v_[static_cast<std::size_t>(j)];
        const Point c = point_at(e, liquid, xi, T_guess, rho_guess);
        const Point m = point_at(em, liquid, xi, c.T, c.rho);
        const Point q = point_at(ep, liquid, xi, c.T, c.rho);
        status = first_error(status, first_error(c.status, first_error(m.status, q.status)));
        T_guess = c.T;
        rho_guess = c.rho;
        table_detail::Node& n = liquid ? liquid_[i * kNxL + static_cast<std::size_t>(j)]
                                       : vapour_[i * kNxV + static_cast<std::size_t>(j)];
        std::array<double, 4>* out[2] = {&n.T, &n.L};
        for (std::size_t k = 0; k < 2; ++k) {
          (*out[k])[0] = c.f[k];
          (*out[k])[1] = c.f_e[k];
          (*out[k])[2] = c.f_x[k];
          (*out[k])[3] = (q.f_x[k] - m.f_x[k]) / (2.0 * kEps);
        }
        // The saturation edge of each table uses the saturation curve data itself, so the
        // single-phase and two-phase evaluations agree exactly on the boundary.
        const bool on_saturation = liquid ? j == nx - 1 : j == 0;
        if (on_saturation) {
          const table_detail::Curve& L = liquid ? ln_rho_l_ : ln_rho_v_;
          n.T[0] = t_sat_.f[i];
          n.T[1] = t_sat_.f_e[i];
          n.L[0] = L.f[i];
          n.L[1] = L.f_e[i];
        }
      }
    }
  }
  build_status_ = status;
}

double PhTable::h_min(double p) const {
  const double eta = std::log(std::clamp(p, kPmin, kPmax));
  const int i = table_detail::find_interval(eta_.data(), kNp, eta);
  const auto k = static_cast<std::size_t>(i);
  const double de = eta_[k + 1] - eta_[k];
  const table_detail::Basis<double> A((eta - eta_[k]) / de);
  double v = 0.0, slope = 0.0;
  table_detail::curve_at(h_min_, i, de, A, v, slope);
  return v;
}

double PhTable::h_max(double p) const {
  const double eta = std::log(std::clamp(p, kPmin, kPmax));
  const int i = table_detail::find_interval(eta_.data(), kNp, eta);
  const auto k = static_cast<std::size_t>(i);
  const double de = eta_[k + 1] - eta_[k];
  const table_detail::Basis<double> A((eta - eta_[k]) / de);
  double v = 0.0, slope = 0.0;
  table_detail::curve_at(h_max_, i, de, A, v, slope);
  return v;
}

const PhTable& ph_table() {
  static const PhTable table;  // thread-safe initialisation; static storage, no heap
  return table;
}

}  // namespace hvac_twin::plant::r32
