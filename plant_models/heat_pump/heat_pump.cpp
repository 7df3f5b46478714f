#include "plant_models/heat_pump/heat_pump.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace hvac_twin::plant {
namespace {

constexpr double kPressureFloor = 0.055e6;  // Pa, inside the property table with a margin
constexpr double kPressureCeiling = 5.55e6;

// Saturation pressure at temperature t [K], by Newton's method on the table's T_sat(p).
double saturation_pressure(double t) {
  double p = 1e6;
  for (int i = 0; i < 50; ++i) {
    const auto s = r32::sat_props(p);
    const double step = (s.T - t) / s.dT_dp;
    p = std::clamp(p - step, kPressureFloor, kPressureCeiling);
    if (std::abs(step) < 1e-9 * p) break;
  }
  return p;
}

std::string indexed(const char* base, std::size_t i) {
  return base + std::to_string(i);
}

}  // namespace

HeatPumpR32::HeatPumpR32(const hp::Params& params)
    : p_(params),
      L_(static_cast<std::size_t>(params.cells), params.augment_gains, params.augment_leak,
         params.end_walls, params.augment),
      n_(static_cast<std::size_t>(params.cells)) {
  if (params.cells < 2 || n_ > kMaxCells)
    throw std::invalid_argument("heat pump: cells must be in [2, " + std::to_string(kMaxCells) +
                                "]");
  if (params.void_fraction < 0 || params.void_fraction > 2 || params.two_phase_htc < 0 ||
      params.two_phase_htc > 2 || params.dp_distribution < 0 || params.dp_distribution > 1)
    throw std::invalid_argument("heat pump: unknown closure");
  if (r32::ph_table().build_status() != r32::Status::kOk)
    throw std::runtime_error("heat pump: the R32 property table failed to build");
  prof_cond_ = profile_options(p_, true, n_);
  prof_evap_ = profile_options(p_, false, n_);
  cache_key_.assign(2 * n_ + 15, 0.0);
  cell_jets_.resize(2 * kMaxCells);
}

hp::ProfileOptions HeatPumpR32::profile_options(const hp::Params& p, bool condenser,
                                                std::size_t cells) {
  const hp::CoilParams& coil = condenser ? p.cond : p.evap;
  hp::ProfileOptions o;
  o.alpha_liquid = p.htc_liquid;
  o.alpha_two_phase = coil.htc_two_phase;
  o.alpha_vapour = p.htc_vapour;
  o.area = coil.inner_area / static_cast<double>(cells);
  o.blend_h = p.htc_blend;
  o.dryout_quality = p.dryout_quality;
  o.alternative_htc = p.two_phase_htc == 2;
  o.heat_sign = condenser ? 1.0 : -1.0;
  o.void_fraction = static_cast<hp::VoidFraction>(p.void_fraction);
  o.htc = p.two_phase_htc == 0 ? hp::TwoPhaseHtc::kConstant
          : condenser          ? hp::TwoPhaseHtc::kCondensing
                               : hp::TwoPhaseHtc::kBoiling;
  o.quadrature = o.void_fraction == hp::VoidFraction::kSmith || o.htc != hp::TwoPhaseHtc::kConstant;
  return o;
}

int HeatPumpR32::solve_pressures(const SideInputs<double>& in, const Conditions& c, double& p_cond,
                                 double& p_evap, std::array<double, 4>& jac,
                                 bool jac_at_solution) const {
  const std::size_t N = n_;
  // The cache: inputs of the last solve.
  bool same = cache_valid_;
  std::size_t at = 0;
  const auto key = [&](double v) {
    if (cache_key_[at] != v) same = false;
    cache_key_[at++] = v;
  };
  key(in.charge);
  key(in.m_cond);
  key(c.speed);
  key(c.t_out);
  key(in.h_dl);
  key(in.h_ll);
  key(in.h_sl);
  key(in.t_air);
  key(in.g_cond);
  key(in.g_evap);
  key(in.comp_flow);
  key(in.void_exponent);
  key(in.cond_htc);
  key(in.evap_htc);
  key(in.friction);
  for (std::size_t k = 0; k < N; ++k) {
    key(in.h_cond[k]);
    key(in.h_evap[k]);
  }
  using D = Dual<2>;
  SideInputs<D> dv;
  // The residuals' Jacobian in the pressures at (pc, pe).
  const auto residual_jacobian = [&](double pc, double pe, D& r1, D& r2, std::array<double, 4>& J) {
    if (side_masses(D(pc, {1.0, 0.0}), D(pe, {0.0, 1.0}), dv, c, r1, r2,
                    static_cast<Eval<D>*>(nullptr)) != kModelOk)
      return false;
    J = {r1.d[0], r1.d[1], r2.d[0], r2.d[1]};
    return true;
  };
  if (same) {
    if (jac_at_solution && !cache_jac_at_solution_) {
      map_inputs(in, dv, [](double v) { return D(v); });
      D r1, r2;
      if (!residual_jacobian(cache_pc_, cache_pe_, r1, r2, cache_jac_)) return kModelRecoverable;
      cache_jac_at_solution_ = true;
    }
    p_cond = cache_pc_;
    p_evap = cache_pe_;
    jac = cache_jac_;
    return kModelOk;
  }

  map_inputs(in, dv, [](double v) { return D(v); });
  bool at_solution = false;
  const auto newton = [&](double pc, double pe) {
    double last = -1.0;  // the last undamped step (relative), < 0 if none
    for (int it = 0; it < 40; ++it) {
      D r1, r2;
      std::array<double, 4> J{};
      if (!residual_jacobian(pc, pe, r1, r2, J)) return false;
      double dpc = 0.0, dpe = 0.0;
      if (!pressure_move(J, r1.v, r2.v, dpc, dpe)) return false;
      const double limit = std::min({1.0, 0.25 * pc / std::abs(dpc), 0.25 * pe / std::abs(dpe)});
      dpc *= limit;
      dpe *= limit;
      pc = std::clamp(pc + dpc, kPressureFloor, kPressureCeiling);
      pe = std::clamp(pe + dpe, kPressureFloor, kPressureCeiling);
      if (!std::isfinite(pc) || !std::isfinite(pe)) return false;
      // Solved to round-off, so that the pressures are smooth functions of the state that
      // finite differences can check. Newton converges quadratically: the step after this one
      // would be about q * step^2, with q measured on the last two steps (0.1-1.5 on the
      // benchmark's warm starts; at least 1 here, 100 with no step before). Stop once that is
      // below 1e-14: this step left the pressures that close to the root, and the iteration
      // that would only confirm it (a third of the solve's cost) is saved. A solve that stalls
      // just above round-off is accepted at 1e-10.
      const double step = std::max(std::abs(dpc) / pc, std::abs(dpe) / pe);
      const double q = last > 0.0 ? std::max(1.0, step / (last * last)) : 100.0;
      if (limit == 1.0 && (q * step * step <= 1e-14 || (it >= 8 && step <= 1e-10))) {
        p_cond = pc;
        p_evap = pe;
        jac = J;
        at_solution = step <= 1e-13;  // as close as the old stopping rule took it
        return true;
      }
      last = limit == 1.0 ? step : -1.0;
    }
    return false;
  };
  double pc0 = 0.0, pe0 = 0.0;
  const bool solved = (predicted_pressures(in, pc0, pe0) && newton(pc0, pe0)) ||
                      (cache_valid_ && newton(cache_pc_, cache_pe_)) || newton(2.5e6, 0.9e6) ||
                      newton(1.5e6, 0.6e6) || newton(4.0e6, 1.5e6);
  cache_valid_ = solved;
  if (!solved) return kModelRecoverable;
  cache_pc_ = p_cond;
  cache_pe_ = p_evap;
  cache_jac_ = jac;
  cache_jac_at_solution_ = at_solution;
  if (jac_at_solution && !at_solution) {
    D r1, r2;
    if (!residual_jacobian(p_cond, p_evap, r1, r2, cache_jac_)) return kModelRecoverable;
    cache_jac_at_solution_ = true;
    jac = cache_jac_;
  }
  return kModelOk;
}

void HeatPumpR32::store_linearisation(const SideInputs<double>& in, const Eval<double>& e,
                                      const std::array<double, 4>& jac) const {
  const std::size_t N = n_;
  Linearisation& l = lin_;
  l.at = in;
  l.p_cond = e.p_cond;
  l.p_evap = e.p_evap;
  l.jac = jac;
  // r_cond = V_dl rho_dl + V_ll rho_ll + sum of the condenser cells' masses - m_cond, and
  // r_evap = V_sl rho_sl + sum of the evaporator cells' masses - (charge - m_cond); cell k's mass
  // depends on its inlet enthalpy (the upstream state) and its own.
  for (std::size_t k = 0; k < N; ++k) {
    l.cond_h[k] = e.cond[k].mass_out + (k + 1 < N ? e.cond[k + 1].mass_in : 0.0);
    l.evap_h[k] = e.evap[k].mass_out + (k + 1 < N ? e.evap[k + 1].mass_in : 0.0);
  }
  l.cond_dl = p_.discharge_line_volume * e.dl.rho_h + e.cond[0].mass_in;
  l.cond_ll = p_.liquid_line_volume * e.ll.rho_h;
  l.evap_ll = e.evap[0].mass_in;
  l.evap_sl = p_.suction_line_volume * e.sl.rho_h;
  l.evap_air = 0.0;
  for (std::size_t k = 0; k < N; ++k)
    l.evap_air += e.evap[k].mass_air;
  l.valid = std::isfinite(l.cond_dl + l.cond_ll + l.evap_ll + l.evap_sl + l.evap_air);
}

bool HeatPumpR32::predicted_pressures(const SideInputs<double>& in, double& p_cond,
                                      double& p_evap) const {
  const Linearisation& l = lin_;
  if (!l.valid) return false;
  const SideInputs<double>& a = l.at;
  double rc =
      l.cond_dl * (in.h_dl - a.h_dl) + l.cond_ll * (in.h_ll - a.h_ll) - (in.m_cond - a.m_cond);
  double re = l.evap_ll * (in.h_ll - a.h_ll) + l.evap_sl * (in.h_sl - a.h_sl) +
              l.evap_air * (in.t_air - a.t_air) - ((in.charge - in.m_cond) - (a.charge - a.m_cond));
  for (std::size_t k = 0; k < n_; ++k) {
    rc += l.cond_h[k] * (in.h_cond[k] - a.h_cond[k]);
    re += l.evap_h[k] * (in.h_evap[k] - a.h_evap[k]);
  }
  double dpc = 0.0, dpe = 0.0;
  if (!pressure_move(l.jac, rc, re, dpc, dpe) || !std::isfinite(dpc) || !std::isfinite(dpe) ||
      std::abs(dpc) > 0.05 * l.p_cond || std::abs(dpe) > 0.05 * l.p_evap)
    return false;
  p_cond = l.p_cond + dpc;
  p_evap = l.p_evap + dpe;
  return true;
}

std::vector<double> HeatPumpR32::initial_state(double t_out_c, double t_zone_c,
                                               double charge) const {
  const std::size_t N = n_;
  const double pc = saturation_pressure(t_out_c + kKelvin + 12.0);
  const double pe = saturation_pressure(t_zone_c + kKelvin - 17.0);
  const auto sat_c = r32::sat_props(pc);
  const auto sat_e = r32::sat_props(pe);
  const double h_dis = sat_c.h_v + 50e3;
  const double h_sub = sat_c.h_l - 9.5e3;  // about 5 K of subcooling
  const double h_suc = sat_e.h_v + 5e3;    // about 4 K of superheat
  // Rated fans, the zone at t_zone; the friction at the rated speed.
  std::vector<double> x(L_.size, 0.0);
  x[L_.t_air] = t_zone_c;
  for (std::size_t f = 0; f < hp::kNumFactors; ++f)
    if (L_.factor[f] != hp::kNone) x[L_.factor[f]] = p_.factor[f];
  const std::vector<double> u{p_.speed_rated, 0.35, 1.0, 1.0, t_out_c};
  SideInputs<double> in = side_inputs(std::span<const double>(x), u);
  const Conditions c{p_.speed_rated, t_out_c + kKelvin};
  // Condenser profile: desuperheating and condensing over the first 1 - phi of the cells, then
  // subcooled liquid; phi is chosen so that the two sides hold `charge`.
  const auto profile = [&](double phi) {
    for (std::size_t k = 0; k < N; ++k) {
      const double s = (static_cast<double>(k) + 1.0) / static_cast<double>(N);  // cell outlet
      in.h_cond[k] = s < 1.0 - phi ? h_dis + (sat_c.h_l - h_dis) * s / (1.0 - phi)
                                   : sat_c.h_l - (sat_c.h_l - h_sub) * (s - 1.0 + phi) / phi;
      in.h_evap[k] = h_sub + (h_suc - h_sub) * s;
    }
    in.h_dl = h_dis;
    in.h_ll = h_sub;
    in.h_sl = h_suc;
  };
  Eval<double> e;
  double mass_cond = 0.0, mass_evap = 0.0;  // residuals with zero masses are the masses
  in.charge = in.m_cond = 0.0;
  const auto masses = [&](double phi) {
    profile(phi);
    if (side_masses(pc, pe, in, c, mass_cond, mass_evap, &e) != kModelOk)
      throw std::runtime_error("heat pump: no initial state at these temperatures");
    return mass_cond + mass_evap;
  };
  double lo = 0.02, hi = 0.9;
  if (masses(lo) < charge && masses(hi) > charge) {
    for (int i = 0; i < 60; ++i) {
      const double mid = 0.5 * (lo + hi);
      (masses(mid) < charge ? lo : hi) = mid;
    }
  }
  masses(0.5 * (lo + hi));

  x[L_.charge] = mass_cond + mass_evap;
  x[L_.m_cond] = mass_cond;
  for (std::size_t k = 0; k < N; ++k) {
    x[L_.h_cond[k]] = 1e-3 * in.h_cond[k];
    x[L_.h_evap[k]] = 1e-3 * in.h_evap[k];
    x[L_.tw_cond[k]] = 0.5 * (e.cond[k].T_out - kKelvin + t_out_c);
    x[L_.tw_evap[k]] = 0.5 * (e.evap[k].T_out - kKelvin + t_zone_c);
  }
  // The end walls start at their cells' walls; their own lag settles them.
  for (std::size_t j = 0; j < L_.tw_end.size; ++j)
    x[L_.tw_end[j]] = x[L_.end_cell_wall(static_cast<hp::End>(j))];
  x[L_.h_dl] = 1e-3 * in.h_dl;
  x[L_.h_ll] = 1e-3 * in.h_ll;
  x[L_.h_sl] = 1e-3 * in.h_sl;
  x[L_.t_mass] = t_zone_c;
  if (L_.q_int != hp::kNone) x[L_.q_int] = p_.internal_gains;
  if (L_.leak != hp::kNone) x[L_.leak] = p_.leak_rate;
  return x;
}

bool HeatPumpR32::initial_guess(std::span<const double> u, std::span<const double> y,
                                std::span<double> x) const {
  const double t_zone =
      std::isfinite(y[hp::kZoneAirTemperature]) ? y[hp::kZoneAirTemperature] : 26.0;
  const std::vector<double> x0 =
      initial_state(u[hp::kOutdoorTemperature], t_zone, p_.nameplate_charge);
  std::copy(x0.begin(), x0.end(), x.begin());
  return true;
}

ModelLayout HeatPumpR32::make_layout() const {
  const std::size_t N = n_;
  const std::vector<double> x0 = initial_state(35.0, 27.0, p_.nameplate_charge);
  ModelLayout l;
  l.states.resize(L_.size);
  const auto set = [&](std::size_t i, std::string name, const char* unit, double lo, double hi,
                       double std0, double q, double abs_tol, bool augmented, std::string desc) {
    l.states[i] = StateInfo{std::move(name), unit,           lo, hi, x0[i], std0, q, abs_tol,
                            augmented,       std::move(desc)};
  };
  // Enthalpy bounds: subcooled liquid at about -50 degC to vapour at 112-161 degC, inside the
  // property table at every pressure the table covers. The table's vapour edge is the 435 K
  // isotherm, whose enthalpy falls with pressure (689 kJ/kg at 0.05 MPa, 641 at 5.6 MPa): an
  // upper bound of 680 held only below 1.1 MPa, and an update that left the discharge line at
  // 662.6 kJ/kg (golden replay, cycle 50) made every pressure solve at the condenser's 3.27 MPa
  // fail, the predictions with it. The pressure solve visits pressures up to its ceiling, so the
  // bound is the table's edge at its highest pressure.
  const double h_lo = 100.0;
  const double h_hi = std::floor(1e-3 * r32::ph_table().h_max(r32::PhTable::kPmax));
  // The charge's noise and bounds are set for leak detection (measured in leak_bench against a
  // 20-cell plant with perturbed parameters): the 10-cell model's charge estimate sits 4-9 % of
  // the nameplate above the plant's, moving with the operating point. With a random walk of
  // 1e-6 kg/sqrt(s) the charge could change only through the leak rate, and a real 46 g loss
  // moved the estimate by 3 g; at 5e-5 it follows a loss (50 of 70 g within 2 h). The upper
  // bound is a plausibility bound, not the nameplate: pinned at the nameplate, the biased
  // estimate could not show a loss smaller than its offset (an overcharged unit exists, too).
  // The nameplate charge is the state's initial value.
  const double m_max = 1.2 * p_.nameplate_charge;
  set(L_.charge, "charge", "kg", 0.0, m_max, 0.05, 5e-5, 1e-9, false,
      "total refrigerant mass in the circuit");
  // M_cond's random walk, and the closures' factors' (hp_params.cpp), are a fifth of what they
  // were before stop 59 (1e-4 kg/sqrt(s) here): they set the pressures' predicted variance, and
  // it over-covered them: the suction pressure's H P- H' was about its sensor's R every cycle
  // while its innovations were R-sized (NIS 0.59). The end walls (end_walls) took the slack the
  // wall sensors had needed. estimation_bench --short --truth all --filters cekf, the circuit's
  // random walks (M_cond, the factors, the cells, walls and lines) scaled by 1 / 0.3 / 0.2 / 0.1
  // (at 0.1 the charge's too): NIS 0.86 / 0.95 / 0.96 / 1.01 on the nominal truth (the suction
  // pressure 0.59 / 0.89 / 0.91 / 0.99), charge +2.18 / +1.88 / +1.92 / +2.11 %; at 0.1 the
  // condenser-outlet pressure and valve-inlet enthalpy were within 2 sigma in only 87-88 % of
  // samples. At 0.2 the cells', walls' and lines' share changed nothing (NIS and charge the same
  // to 0.01 and 0.05 %) and left the integration's error in a transient as large as their noise
  // (filter_transition_test), so they keep theirs. The charge keeps its own: it is how a loss is
  // followed (leak_bench).
  set(L_.m_cond, "M_cond", "kg", 0.0, m_max, 0.05, 2e-5, 1e-9, false,
      "refrigerant mass on the high side: discharge line, condenser, liquid line");
  for (std::size_t k = 0; k < N; ++k) {
    set(L_.h_cond[k], indexed("h_cond_", k), "kJ/kg", h_lo, h_hi, 10.0, 0.05, 1e-3, false,
        "condenser cell enthalpy");
    set(L_.tw_cond[k], indexed("Tw_cond_", k), "degC", -40.0, 150.0, 2.0, 0.01, 1e-4, false,
        "condenser wall temperature");
    set(L_.h_evap[k], indexed("h_evap_", k), "kJ/kg", h_lo, h_hi, 10.0, 0.05, 1e-3, false,
        "evaporator cell enthalpy");
    set(L_.tw_evap[k], indexed("Tw_evap_", k), "degC", -40.0, 150.0, 2.0, 0.01, 1e-4, false,
        "evaporator wall temperature");
  }
  constexpr std::array<const char*, hp::kNumEnds> kEndName{"Tw_end_cond_in", "Tw_end_cond_out",
                                                           "Tw_end_evap_in", "Tw_end_evap_out"};
  // The end walls' random walk, 0.05 K/sqrt(s) against the cells' 0.01: what the model does not
  // know of the strip a sensor sits on (the local heat transfer and the end's refrigerant state,
  // by closures; where exactly the sensor sits) is the model error the wall sensors' 0.25 K of
  // representativeness stood for before these states, and the strip's relaxation keeps it from
  // growing. Measured (stop 58, estimation_bench --short --truth all --filters cekf): charge
  // +1.87 / +1.86 / +0.91 % with it, +2.03 / +1.84 / +1.12 % with 0.01; with 0.01 the replay's
  // smoother diverged on the golden recording (its COP 11, the filter's 0.18, RMS).
  for (std::size_t j = 0; j < L_.tw_end.size; ++j)
    set(L_.tw_end[j], kEndName[j], "degC", -40.0, 150.0, 5.0, 0.05, 1e-4, false,
        "wall temperature at a sensed coil end (the sensor's local wall)");
  set(L_.h_ll, "h_liquid_line", "kJ/kg", h_lo, h_hi, 10.0, 0.05, 1e-3, false,
      "liquid-line enthalpy: the expansion-valve inlet");
  set(L_.h_sl, "h_suction_line", "kJ/kg", h_lo, h_hi, 10.0, 0.05, 1e-3, false,
      "suction-line enthalpy: the compressor inlet");
  set(L_.t_air, "T_air", "degC", -40.0, 70.0, 1.0, 1e-3, 1e-6, false, "zone air temperature");
  set(L_.t_mass, "T_mass", "degC", -40.0, 70.0, 3.0, 5e-4, 1e-6, false,
      "building-mass temperature");
  l.states[L_.t_air].held_while_settling = l.states[L_.t_mass].held_while_settling = true;
  // The zone's gains: the zone air tells the filter their sum with the building mass's heat, and
  // the two come apart only over many hours, so the gains' sigma is what it publishes for most
  // of a day, and it must be as wide as what it does not know. The prior: 300 +- 500 W, the
  // gains of a zone one split unit serves (40-70 m2 at 0-20 W/m2 of people, lighting and
  // equipment). The random walk, 2 W/sqrt(s): occupancy switching by a few hundred watts a few
  // times a day. estimation_bench, nominal truth, a day (gains drawn from 200-1200 W every 3 h):
  // the gains' e^2/sigma^2 averaged 2.40 with 1 W/sqrt(s), 0.83 with 2, 0.30 with 4; over units
  // drawn from the priors (--sample-truth 1..8, 3 h each) the NEES averaged 6.4 with the prior
  // 300 +- 300 W (a unit's gains of 1104 W gave 9.9), 4.1 with +- 500.
  if (L_.q_int != hp::kNone)
    set(L_.q_int, "Q_int", "W", -2000.0, 20000.0, 500.0, 2.0, 1e-3, true,
        "internal heat gains (random walk)");
  // The leak rate is the charge's trend over about two days (random walk 1e-3 g/h/sqrt(s)),
  // signed: at a lower bound of 0 the PDF truncation collapsed its sigma to ~0.02 g/h and held
  // the charge up; a negative value is the model's wander, not refrigerant gained.
  if (L_.leak != hp::kNone)
    set(L_.leak, "leak_rate", "g/h", -50.0, 1000.0, 2.0, 1e-3, 1e-6, true,
        "refrigerant leak rate (random walk; negative: no loss seen)");
  for (std::size_t f = 0; f < hp::kNumFactors; ++f) {
    if (L_.factor[f] == hp::kNone) continue;
    const hp::FactorInfo& info = hp::factor_info()[f];
    set(L_.factor[f], info.name, info.unit, info.min, info.max, info.initial_std,
        info.process_noise, 1e-9, true, info.description);
    l.states[L_.factor[f]].consider = info.consider || info.calibrate;
    l.states[L_.factor[f]].calibrate = info.calibrate;
    // Every factor describes the running cycle: with the compressor stopped no sensor sees a
    // coefficient or an efficiency (leak_bench, 4 h off: the void exponent moved 0.69 -> 0.77
    // on the innovations of the standing unit, and the next start began from there).
    l.states[L_.factor[f]].excited_by = static_cast<int>(hp::kCompressorSpeed);
    l.states[L_.factor[f]].excitation_min = hp::kStoppedBelowHz;
  }
  // The zone's temperatures, its gains and the leak rate reach the refrigerant's equations only
  // through small terms (the air's rate of change in the indoor coil's balance, a leak beside a
  // flow 10^4 times larger): moved by 2 initial sigma each, at the settled nominal point, the
  // Jacobian changes by less than 1e-4 of itself, where a cell enthalpy moved by 0.1 sigma
  // changes it by 4e-3 to 2e-2 (plant_models_test "states the Jacobian barely depends on").
  // Their moves alone need no new Jacobian: their reuse unit is their range. (An EnKF member
  // evaluated 0.8 Jacobians a period, in 10 572 of 25 826 requests only because the gains or
  // the leak rate differed from the lane's last member by more than 2 sigma.)
  for (const std::size_t i : {L_.t_air, L_.t_mass, L_.q_int, L_.leak})
    if (i != hp::kNone) l.states[i].reuse_scale = l.states[i].max - l.states[i].min;
  // The unit's properties, kept across an outage longer than estimator.checkpoint_max_age_s;
  // the refrigerant's distribution, the walls and the zone are re-settled.
  for (std::size_t i = 0; i < L_.size; ++i)
    l.states[i].persistent =
        i == L_.charge || i == L_.leak || (l.states[i].augmented && i != L_.q_int);
  set(L_.h_dl, "h_discharge_line", "kJ/kg", h_lo, h_hi, 10.0, 0.05, 1e-3, false,
      "discharge-line enthalpy: the condenser inlet");

  // At rest the refrigerant circuit is not observable: the valve shut, the low side evaporates
  // to vapour whose mass its pressure and temperature give, but the high side stays two-phase at
  // the saturation pressure of its temperature whatever it holds, and the walls follow the air.
  // Updated on the standing unit's innovations, the filter moved refrigerant between cells and
  // sides to fit sensors that do not see it: in leak_bench (a)'s night stop the heat-flow
  // estimates wandered by up to 1.6 kW around the truth's zero (mean 0.41 kW). So while the
  // compressor stands every state of the circuit is predicted, not updated (est::StatePhases;
  // the closures above likewise), its sigma growing with its process noise; the measurements
  // still update the zone, and the circuit's first updates after the start correct it. (Tried
  // before the "condenser above evaporator" constraint was conditioned on the compressor, this
  // failed: the constraint, enforced at rest, was projected onto the zone's states alone.)
  for (std::size_t i = 0; i < L_.size; ++i) {
    if (i == L_.t_air || i == L_.t_mass || i == L_.q_int) continue;
    l.states[i].excited_by = static_cast<int>(hp::kCompressorSpeed);
    l.states[i].excitation_min = hp::kStoppedBelowHz;
  }

  // Beyond the bounds: each side keeps some refrigerant (a side without refrigerant has no
  // pressure: the low side's 0.75 L of vapour at the table's lowest pressure hold about 2 g; a
  // working unit's low side holds only ~5 % of the charge, so the bound must stay well below
  // that), and the condenser stays above the evaporator with the pressures in operating range
  // (outputs: linearised by the constrained update).
  using C = LinearConstraint;
  const double m_min = 0.01 * p_.nameplate_charge;
  l.constraints = {
      C{"high side holds refrigerant", C::Over::kStates, {{L_.m_cond, -1.0}}, -m_min},
      C{"low side holds refrigerant",
        C::Over::kStates,
        {{L_.m_cond, 1.0}, {L_.charge, -1.0}},
        -m_min},
      // Only while the compressor runs: at rest the pressures equalise through an open valve,
      // and with the valve shut each side's follows its own air; on a night stop the outdoor
      // coil (the high side) falls below the zone's saturation pressure. Enforced at rest, the
      // projection pushed refrigerant into the high side until its liquid was compressed above
      // the low side's pressure: leak_bench (c)'s charge ran from 0.528 kg to its 0.600 kg
      // bound in an hour of a night stop (truth 0.495).
      C{"condenser above evaporator",
        C::Over::kOutputs,
        {{hp::kSuctionPressure, 1.0}, {hp::kDischargePressure, -1.0}},
        -50e3,
        static_cast<int>(hp::kCompressorSpeed),
        hp::kStoppedBelowHz},
      C{"suction pressure in range", C::Over::kOutputs, {{hp::kSuctionPressure, -1.0}}, -0.15e6},
      C{"discharge pressure in range", C::Over::kOutputs, {{hp::kDischargePressure, 1.0}}, 5.2e6},
  };

  l.inputs.resize(hp::kNumInputs);
  l.inputs[hp::kCompressorSpeed] = {"compressor_speed", "Hz", 0.0, 150.0, kRequired,
                                    "compressor speed"};
  l.inputs[hp::kValveOpening] = {"valve_opening",
                                 "1",
                                 0.0,
                                 1.0,
                                 kRequired,
                                 "expansion-valve opening, fraction of full stroke"};
  l.inputs[hp::kIndoorFan] = {"indoor_fan", "1", 0.0,
                              1.5,          1.0, "indoor fan speed, fraction of rated air flow"};
  l.inputs[hp::kOutdoorFan] = {"outdoor_fan", "1", 0.0,
                               1.5,           1.0, "outdoor fan speed, fraction of rated air flow"};
  l.inputs[hp::kOutdoorTemperature] = {"outdoor_temperature",
                                       "degC",
                                       -30.0,
                                       55.0,
                                       kRequired,
                                       "outdoor air temperature (condenser air inlet)"};
  // How far an input may move before a Jacobian evaluated at its old value is evaluated again
  // (in the same fraction as the states' initial_std): each moves the coils' duty about as much
  // as a state moving by its own scale does (a wall temperature's 2 K, a cell enthalpy's
  // 10 kJ/kg): 5 Hz of the compressor's speed is 10 % of its flow at 50 Hz, a valve's 0.05 of
  // its stroke 13 % of its opening at 0.37, a fan's 0.05 of rated flow 5 % of the air side's
  // conductance, 2 K of outdoor air as much as the condenser's wall.
  l.inputs[hp::kCompressorSpeed].reuse_scale = 5.0;
  l.inputs[hp::kValveOpening].reuse_scale = 0.05;
  l.inputs[hp::kIndoorFan].reuse_scale = 0.05;
  l.inputs[hp::kOutdoorFan].reuse_scale = 0.05;
  l.inputs[hp::kOutdoorTemperature].reuse_scale = 2.0;

  l.outputs.resize(hp::kNumOutputs);
  const auto out = [&](hp::Output o, const char* name, const char* unit, double lo, double hi,
                       const char* desc) {
    l.outputs[o] = SignalInfo{name, unit, lo, hi, kRequired, desc};
  };
  using namespace hp;
  out(kSuctionPressure, "suction_pressure", "Pa", 0.0, 6e6, "compressor suction pressure");
  out(kDischargePressure, "discharge_pressure", "Pa", 0.0, 6e6, "compressor discharge pressure");
  out(kCondWallTempIn, "cond_wall_temperature_in", "degC", -40, 150, "condenser inlet wall");
  out(kCondWallTempOut, "cond_wall_temperature_out", "degC", -40, 150, "condenser outlet wall");
  out(kEvapWallTempIn, "evap_wall_temperature_in", "degC", -40, 150, "evaporator inlet wall");
  out(kEvapWallTempOut, "evap_wall_temperature_out", "degC", -40, 150, "evaporator outlet wall");
  out(kZoneAirTemperature, "zone_air_temperature", "degC", -40, 70, "zone air temperature");
  out(kSupplyAirTemperature, "supply_air_temperature", "degC", -40, 70,
      "air leaving the indoor coil");
  out(kCompressorPower, "compressor_power", "W", 0, 1e5, "compressor electric power");
  out(kCondenserOutletPressure, "condenser_outlet_pressure", "Pa", 0, 6e6,
      "condenser outlet (liquid line) pressure");
  out(kValveInletEnthalpy, "valve_inlet_enthalpy", "kJ/kg", 0, 800,
      "specific enthalpy at the expansion-valve inlet");
  out(kCondenserHeatFlow, "condenser_heat_flow", "W", -1e5, 1e5,
      "heat from the refrigerant to the condenser wall");
  out(kEvaporatorHeatFlow, "evaporator_heat_flow", "W", -1e5, 1e5,
      "heat from the evaporator wall to the refrigerant");
  out(kCoolingCapacity, "cooling_capacity", "W", -1e5, 1e5,
      "heat taken from the indoor air (sensible)");
  out(kRefrigerantMassFlow, "refrigerant_mass_flow", "kg/s", 0, 1, "compressor mass flow");
  out(kDischargeTemperature, "discharge_temperature", "degC", -40, 200,
      "compressor discharge temperature");
  out(kSuperheat, "superheat", "K", -50, 100, "superheat at the compressor inlet");
  out(kSubcooling, "subcooling", "K", -50, 100, "subcooling at the expansion-valve inlet");
  out(kCop, "cop", "1", -10, 20, "coefficient of performance: cooling capacity / power");
  out(kCharge, "charge", "kg", 0, 5, "refrigerant charge");
  out(kLeakRate, "leak_rate", "g/h", -1e4, 1e4, "refrigerant leak rate");
  out(kMassTemperature, "mass_temperature", "degC", -40, 70, "building-mass temperature");
  out(kInternalGains, "internal_gains", "W", -2000, 20000, "internal heat gains");
  out(kOutdoorCoilFouling, "outdoor_coil_fouling", "1", 0, 2,
      "outdoor-coil air-side UA factor (1 = clean)");

  // Structural errors of the virtual sensors: what the model's closures and cells leave in an
  // output however well its state is known (plant_models/README.md, "Honest sigma"), one sigma,
  // absolute and relative in quadrature. From the filter's errors against the benchmark truths
  // (estimation_bench: converged cells, Smith void fraction, other two-phase correlations; with
  // and without parameter mismatch), the share of each error its own sigma does not explain:
  //  - charge 4 %: the refrigerant the model holds at given pressures and temperatures rests on
  //    its void-fraction closure; with Smith's instead of Zivi's the same measurements mean 3-4 %
  //    less charge whatever the filter estimates (no sensor tells a void fraction from a charge);
  //  - superheat 0.5 K: the evaporator's dryout and superheated zone, a few cells at the outlet
  //    whose heat transfer falls with quality by a correlation (dryout from x 0.75 or 0.8);
  //  - subcooling 0.18 K, valve-inlet enthalpy 0.35 kJ/kg (the liquid's cp, 1.9 kJ/kg/K, times
  //    the subcooling's): the subcooled zone's length between the condensing and single-phase
  //    heat transfer, and a coil UA the filter has not yet learnt;
  //  - cooling capacity and COP 0.3 %, heat flows 0.5 %, condenser-outlet pressure 0.08 % (a
  //    twelfth of the coil's friction drop): air-side and friction closures.
  //  The last three were 0.1 K, 0.2 kJ/kg and 0.05 % while M_cond's and the closures' random
  //  walks were five times larger (M_cond above) and their spread covered the rest. With the
  //  narrower walks (and the cells' narrower too, a variant not kept) on the mismatched truth
  //  (coil UA -20/+20 %) only 73 % of the valve-inlet enthalpy's errors and 76 % of the
  //  subcooling's were within 2 sigma, with 0.4 and 0.2 98 %. As kept, with 0.35 kJ/kg and
  //  0.18 K: 96.7 % and 98.7 % (nominal truth 100 %: the error there is smaller than this floor;
  //  estimation_bench --short --truth all).
  //  - leak rate 3 g/h: the charge's offset moves with the operating point, and the filter reads
  //    its drift as a trend (leak_bench, scenario (a), no leak: the estimate wandered to
  //    +3.5 g/h over 18 h while its own sigma was 0.8 g/h, 4 sigma). The detector judges the
  //    rate on this sigma; slow leaks it finds by the charge deficit against its references.
  const auto structural = [&](hp::Output o, double abs, double rel) {
    l.outputs[o].model_error = abs;
    l.outputs[o].model_error_rel = rel;
  };
  structural(kCharge, 0.0, 0.04);
  structural(kSuperheat, 0.5, 0.0);
  structural(kSubcooling, 0.18, 0.0);
  structural(kValveInletEnthalpy, 0.35, 0.0);
  structural(kCondenserHeatFlow, 0.0, 0.005);
  structural(kEvaporatorHeatFlow, 0.0, 0.005);
  structural(kCoolingCapacity, 0.0, 0.003);
  structural(kCop, 0.0, 0.003);
  structural(kCondenserOutletPressure, 0.0, 0.0008);
  structural(kLeakRate, 3.0, 0.0);
  return l;
}

}  // namespace hvac_twin::plant
