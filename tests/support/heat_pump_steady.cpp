#include "tests/support/heat_pump_steady.hpp"

#include <algorithm>
#include <cmath>
#include <memory>
#include <stdexcept>
#include <vector>

#include "plant_models/catalog.hpp"
#include "plant_models/core/ad_model.hpp"
#include "plant_models/core/integrator.hpp"
#include "plant_models/heat_pump/heat_pump.hpp"
#include "plant_models/heat_pump/hp_profile.hpp"
#include "plant_models/refrigerant/r32_smooth.hpp"

namespace hvac_twin::test {
namespace {

using namespace plant::hp;
namespace r32 = plant::r32;
constexpr double kKelvin = 273.15;

// ---------------------------------------------------------------------------------------------
// The model at steady state.

SteadyAnswer answer_of(const std::vector<double>& y) {
  SteadyAnswer a;
  a.subcooling = y[kSubcooling];
  a.superheat = y[kSuperheat];
  a.p_discharge = y[kDischargePressure];
  a.p_suction = y[kSuctionPressure];
  a.tw_cond_in = y[kCondWallTempIn];
  a.tw_cond_out = y[kCondWallTempOut];
  a.tw_evap_in = y[kEvapWallTempIn];
  a.tw_evap_out = y[kEvapWallTempOut];
  a.q_cond = y[kCondenserHeatFlow];
  a.q_evap = y[kEvaporatorHeatFlow];
  return a;
}

}  // namespace

namespace {

// The model with `params` at `cells`, the zone held at its temperature: 1e13 J/K drifts by
// microkelvin in hours.
std::unique_ptr<plant::ContinuousModel> held_zone_model(const plant::ParameterMap& params,
                                                        int cells) {
  plant::ParameterMap p = params;
  p["cells"] = cells;
  p["zone_C_air"] = 1e13;
  p["zone_C_mass"] = 1e13;
  return plant::create_model("heat_pump_r32", p);
}

plant::IntegratorOptions tight() {
  plant::IntegratorOptions o;
  o.rel_tol = 1e-9;
  return o;
}

// Integrates x at inputs u until the outputs stop moving (relative change below 1e-6 over 10
// minutes: the held zone still drifts by ~1e-7 K), at most 6 h; the settled outputs.
std::vector<double> settle(const plant::ContinuousModel& model, std::vector<double>& x,
                           const std::vector<double>& u) {
  plant::Integrator integ(model, tight());
  std::vector<double> y(model.num_outputs()), last;
  for (int chunk = 0; chunk < 36; ++chunk) {
    if (!integ.step(x, u, 600.0, {}).ok())
      throw std::runtime_error(std::string("steady state not reached: ") + integ.last_error());
    if (model.outputs(x, u, y) != plant::kModelOk) throw std::runtime_error("outputs failed");
    bool settled = !last.empty();
    for (std::size_t i = 0; i < y.size() && settled; ++i)
      settled = std::abs(y[i] - last[i]) <= 1e-6 * std::max(1.0, std::abs(y[i]));
    if (settled) return y;
    last = y;
  }
  throw std::runtime_error("steady state not reached in 6 h");
}

std::vector<double> initial_state(const plant::ContinuousModel& model, const OperatingPoint& op,
                                  double charge) {
  const auto& hp = dynamic_cast<const plant::AdModel<plant::HeatPumpR32>&>(model).model();
  return hp.initial_state(op.t_out, op.t_zone, charge);
}

std::vector<double> inputs(const OperatingPoint& op) {
  return {op.speed, op.valve, 1.0, 1.0, op.t_out};
}

}  // namespace

SteadyAnswer model_steady(const plant::ParameterMap& params, int cells, const OperatingPoint& op,
                          double charge) {
  const auto model = held_zone_model(params, cells);
  std::vector<double> x = initial_state(*model, op, charge);
  return answer_of(settle(*model, x, inputs(op)));
}

std::vector<MeasuredPoints> model_transient(const plant::ParameterMap& params, int cells,
                                            const OperatingPoint& op, double charge) {
  const auto model = held_zone_model(params, cells);
  std::vector<double> x = initial_state(*model, op, charge);
  std::vector<double> u = inputs(op);
  std::vector<double> y = settle(*model, x, u);
  const auto measured = [&y] {
    return MeasuredPoints{y[kSuctionPressure], y[kDischargePressure], y[kCondWallTempIn],
                          y[kCondWallTempOut], y[kEvapWallTempIn],    y[kEvapWallTempOut]};
  };
  std::vector<MeasuredPoints> out{measured()};
  plant::Integrator integ(*model, tight());
  for (int t = 0; t < kTransientSeconds; ++t) {
    const bool hunting = t < kTransientSeconds / 2;
    u[kValveOpening] = hunting ? op.valve * ((t / 25) % 2 == 0 ? 1.05 : 0.95) : op.valve;
    u[kCompressorSpeed] = hunting ? op.speed : op.speed + 8.0;
    if (!integ.step(x, u, 1.0, {}).ok())
      throw std::runtime_error(std::string("transient failed: ") + integ.last_error());
    if (model->outputs(x, u, y) != plant::kModelOk) throw std::runtime_error("outputs failed");
    out.push_back(measured());
  }
  return out;
}

MotionError motion_error(const std::vector<MeasuredPoints>& run,
                         const std::vector<MeasuredPoints>& ref, std::size_t j) {
  MotionError m;
  const std::size_t n = std::min(run.size(), ref.size());
  for (std::size_t t = 1; t < n; ++t) {
    const double e = (run[t][j] - run[0][j]) - (ref[t][j] - ref[0][j]);
    m.rms += e * e;
    m.largest = std::max(m.largest, std::abs(e));
  }
  if (n > 1) m.rms = std::sqrt(m.rms / static_cast<double>(n - 1));
  return m;
}

double model_charge_for_subcooling(const plant::ParameterMap& params, int cells,
                                   const OperatingPoint& op, double subcooling) {
  double m0 = 0.5, m1 = 0.51;
  double f0 = model_steady(params, cells, op, m0).subcooling - subcooling;
  double f1 = model_steady(params, cells, op, m1).subcooling - subcooling;
  for (int it = 0; it < 20 && std::abs(f1) > 1e-4; ++it) {
    const double m2 = m1 - f1 * (m1 - m0) / (f1 - f0);
    m0 = m1;
    f0 = f1;
    m1 = std::clamp(m2, 0.2, 0.8);
    f1 = model_steady(params, cells, op, m1).subcooling - subcooling;
  }
  if (std::abs(f1) > 1e-3) throw std::runtime_error("no charge reproduces the subcooling");
  return m1;
}

// ---------------------------------------------------------------------------------------------
// The continuous reference.

namespace {

struct Coil {
  const CoilParams& coil;
  ProfileOptions profile;  // area = the whole coil
  double g_air;            // W/K, the whole coil's air side
  double t_air;            // K
  double htc_factor;       // on the two-phase heat transfer coefficient
  double void_exponent;    // of the slip-ratio void fraction
};

struct CoilResult {
  double h_out, mass, heat, tw_in, tw_out;
};

double local_density(const ProfileOptions& o, double exponent, double p, double h) {
  const auto sat = r32::sat_props(p);
  if (h > sat.h_v || h < sat.h_l) return r32::ph_props(p, h).rho;
  const double x = (h - sat.h_l) / (sat.h_v - sat.h_l);
  const double a =
      profile_detail::void_fraction(o.void_fraction, x, sat.rho_v / sat.rho_l, exponent);
  return sat.rho_l - (sat.rho_l - sat.rho_v) * a;
}

// The wall in local balance with the refrigerant at (p, h) and the air.
double local_wall(const Coil& c, double p, double h) {
  const auto sat = r32::sat_props(p);
  const double a = local_alpha(c.profile, h, sat.h_l, sat.h_v, c.htc_factor) * c.profile.area;
  const double t = r32::ph_props(p, h).T;
  return (a * t + c.g_air * c.t_air) / (a + c.g_air) - kKelvin;
}

// Integrates one coil from h_in at p_in (pressure falling linearly by dp) with flow mdot.
CoilResult integrate(const Coil& c, double p_in, double dp, double h_in, double mdot, int steps) {
  const auto slope = [&](double s, double h) {
    const double p = p_in - dp * s;
    const auto sat = r32::sat_props(p);
    const double a = local_alpha(c.profile, h, sat.h_l, sat.h_v, c.htc_factor) * c.profile.area;
    const double u = a * c.g_air / (a + c.g_air);
    return u * (c.t_air - r32::ph_props(p, h).T) / mdot;
  };
  const double ds = 1.0 / steps;
  double h = h_in, mass = 0.0;
  for (int i = 0; i < steps; ++i) {
    const double s = i * ds;
    const double k1 = slope(s, h), k2 = slope(s + 0.5 * ds, h + 0.5 * ds * k1);
    const double k3 = slope(s + 0.5 * ds, h + 0.5 * ds * k2), k4 = slope(s + ds, h + ds * k3);
    const double h_next = h + ds / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    const double h_mid = h + 0.5 * ds * k2;  // the RK4 midpoint estimate
    mass += ds / 6.0 *
            (local_density(c.profile, c.void_exponent, p_in - dp * s, h) +
             4.0 * local_density(c.profile, c.void_exponent, p_in - dp * (s + 0.5 * ds), h_mid) +
             local_density(c.profile, c.void_exponent, p_in - dp * (s + ds), h_next));
    h = h_next;
  }
  return {h, mass * c.coil.volume, mdot * (h - h_in), local_wall(c, p_in, h_in),
          local_wall(c, p_in - dp, h)};
}

}  // namespace

SteadyAnswer continuous_steady(const plant::ParameterMap& params, const OperatingPoint& op,
                               double charge, int steps) {
  const Params P = params_from_map(params);
  if (P.dp_distribution != 0)
    throw std::invalid_argument("continuous reference: uniform friction distribution only");
  // The closures of a whole coil (one cell's area is the coil's).
  const auto coil = [&](const CoilParams& cp, bool condenser, double t_air) {
    const AirSide air = air_side(cp, 1.0, P.fan_ua_exponent, 1);
    const double ua = P.factor[condenser ? kCondUa : kEvapUa];
    return Coil{cp,
                plant::HeatPumpR32::profile_options(P, condenser, 1),
                air.capacity_rate * (1.0 - std::exp(-air.ntu * ua)),
                t_air + kKelvin,
                P.factor[condenser ? kCondHtc : kEvapHtc],
                P.factor[kVoidExponent]};
  };
  const Coil cond = coil(P.cond, true, op.t_out), evap = coil(P.evap, false, op.t_zone);

  struct Eval {
    std::array<double, 3> r{};
    SteadyAnswer a;
  };
  const auto evaluate = [&](const std::array<double, 3>& z) {
    const double pc = z[0], pe = z[1], h_suc = z[2];
    const auto suc = r32::smooth_ph(pe, h_suc, P.smoothing_width);
    auto comp = compressor(P, pe, suc.rho, h_suc, pc, op.speed);
    comp.mdot *= P.factor[kCompFlow];
    comp.h_dis = h_suc + (comp.h_dis - h_suc) / P.factor[kCompWork];
    const double flow = comp.mdot / P.nominal_mass_flow;
    const double drop = P.factor[kFriction] * std::pow(flow, P.dp_exponent);
    const double dpc = P.cond.dp_nominal * drop, dpe = P.evap.dp_nominal * drop;
    const CoilResult c = integrate(cond, pc, dpc, comp.h_dis, comp.mdot, steps);
    const auto ll = r32::smooth_ph(pc - dpc, c.h_out, P.smoothing_width);
    const double mv = P.factor[kValve] * valve_flow(P, op.valve, ll.rho, (pc - dpc) - (pe + dpe));
    const CoilResult e = integrate(evap, pe + dpe, dpe, c.h_out, comp.mdot, steps);
    const double dl = r32::smooth_ph(pc, comp.h_dis, P.smoothing_width).rho;
    const double mass = c.mass + e.mass + P.discharge_line_volume * dl +
                        P.liquid_line_volume * ll.rho + P.suction_line_volume * suc.rho;
    Eval out;
    out.r = {(mv - comp.mdot) / comp.mdot, (e.h_out - h_suc) / 1e4, (mass - charge) / charge};
    out.a.subcooling = r32::sat_props(pc - dpc).T - ll.T;
    out.a.superheat = suc.T - r32::sat_props(pe).T;
    out.a.p_discharge = pc;
    out.a.p_suction = pe;
    out.a.tw_cond_in = c.tw_in;
    out.a.tw_cond_out = c.tw_out;
    out.a.tw_evap_in = e.tw_in;
    out.a.tw_evap_out = e.tw_out;
    out.a.q_cond = -c.heat;
    out.a.q_evap = e.heat;
    return out;
  };

  // Newton with a finite-difference Jacobian from typical pressures.
  std::array<double, 3> z{2.9e6, 0.95e6, r32::sat_props(0.95e6).h_v + 8e3};
  const std::array<double, 3> step{10.0, 10.0, 1.0};
  for (int it = 0; it < 60; ++it) {
    const Eval f = evaluate(z);
    if (std::abs(f.r[0]) + std::abs(f.r[1]) + std::abs(f.r[2]) < 1e-11) return f.a;
    double J[3][4];
    for (int j = 0; j < 3; ++j) {
      auto zp = z;
      zp[j] += step[j];
      const Eval fp = evaluate(zp);
      for (int i = 0; i < 3; ++i)
        J[i][j] = (fp.r[i] - f.r[i]) / step[j];
    }
    for (int i = 0; i < 3; ++i)
      J[i][3] = -f.r[i];
    for (int col = 0; col < 3; ++col) {  // Gaussian elimination, partial pivoting
      int piv = col;
      for (int i = col + 1; i < 3; ++i)
        if (std::abs(J[i][col]) > std::abs(J[piv][col])) piv = i;
      std::swap(J[col], J[piv]);
      for (int i = col + 1; i < 3; ++i) {
        const double m = J[i][col] / J[col][col];
        for (int j = col; j < 4; ++j)
          J[i][j] -= m * J[col][j];
      }
    }
    std::array<double, 3> d{};
    for (int i = 2; i >= 0; --i) {
      double s = J[i][3];
      for (int j = i + 1; j < 3; ++j)
        s -= J[i][j] * d[j];
      d[i] = s / J[i][i];
    }
    double limit = 1.0;
    for (int i = 0; i < 2; ++i)
      if (std::abs(d[i]) > 0.2 * z[i]) limit = std::min(limit, 0.2 * z[i] / std::abs(d[i]));
    if (std::abs(d[2]) > 20e3) limit = std::min(limit, 20e3 / std::abs(d[2]));
    for (int i = 0; i < 3; ++i)
      z[i] += limit * d[i];
  }
  throw std::runtime_error("continuous reference: no steady state");
}

}  // namespace hvac_twin::test
