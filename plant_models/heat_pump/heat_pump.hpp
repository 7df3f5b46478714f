// R32 vapour-compression heat pump in cooling mode with the zone it serves, written once over
// the scalar type (see plant_models/README.md for every equation, with units).
//
//   compressor -> discharge line -> condenser (N cells) -> liquid line -> expansion valve
//   -> evaporator (N cells) -> suction line -> compressor;   the evaporator's air is the zone's.
//
// Conservative formulation. The high-side refrigerant mass M_cond and the total charge are
// states; the low-side mass is charge - M_cond. Their derivatives are flow differences
// (dM_cond/dt = mdot_comp - mdot_valve, dcharge/dt = -leak), linear in the state, which a BDF
// integrator preserves exactly, so the refrigerant inventory is conserved to round-off. The
// condenser-inlet and evaporator-outlet pressures are algebraic: each is the pressure at which
// the masses of that side's cells add up to its mass, solved by Newton's method (2 x 2, since the
// friction depends on the compressor flow) to round-off; their derivatives with respect to the
// state follow from the implicit-function theorem.
//
// Cells. A coil cell's state is its outlet enthalpy; its refrigerant mass and its heat exchange
// with the wall are means over the profile between its inlet (the upstream state) and its outlet
// (hp_profile.hpp), which makes the steady answers nearly independent of the cell count. The
// cell balances march from each coil's inlet with one common dp/dt per side that makes the last
// cell's outflow equal the downstream component's flow (affine in dp/dt).
//
// A model instance caches the last pressure solution (warm start, and reuse across the
// derivative chunks of one Jacobian), so it serves one thread; AdModel::clone() makes another.
// Evaluation never allocates and never throws; a state without a pressure solution, or outside
// the property tables, is a recoverable error (status > 0).
#pragma once

#include <array>
#include <cmath>
#include <span>
#include <vector>

#include "plant_models/core/model.hpp"
#include "plant_models/core/model_info.hpp"
#include "plant_models/heat_pump/hp_components.hpp"
#include "plant_models/heat_pump/hp_layout.hpp"
#include "plant_models/heat_pump/hp_params.hpp"
#include "plant_models/heat_pump/hp_profile.hpp"

namespace hvac_twin::plant {

class HeatPumpR32 {
 public:
  static constexpr const char* kType = "heat_pump_r32";
  static constexpr std::size_t kMaxCells = 40;

  explicit HeatPumpR32(const hp::Params& params);
  explicit HeatPumpR32(const ParameterMap& values) : HeatPumpR32(hp::params_from_map(values)) {}

  [[nodiscard]] static std::vector<ParameterInfo> parameter_info() { return hp::parameter_info(); }
  [[nodiscard]] ModelLayout layout() const { return make_layout(); }
  [[nodiscard]] const hp::Params& params() const { return p_; }
  [[nodiscard]] const hp::Layout& slots() const { return L_; }
  // The cell-profile closures of one coil divided into `cells` cells (area per cell).
  [[nodiscard]] static hp::ProfileOptions profile_options(const hp::Params& p, bool condenser,
                                                          std::size_t cells);

  // Drops the pressure solve's warm start and the cell jets, so that what follows does not
  // depend on what was evaluated before (a clone starts so: AdModel::clone).
  void forget_warm_starts() const {
    cache_valid_ = false;
    lin_.valid = false;
    for (auto& jet : cell_jets_)
      jet.valid = false;
  }

  template <class S>
  int rhs(std::span<const S> x, std::span<const double> u, std::span<S> xdot) const;
  template <class S>
  int outputs(std::span<const S> x, std::span<const double> u, std::span<S> y) const;

  // A consistent state holding `charge` [kg] at the given temperatures, for start-up and tests:
  // typical pressures, enthalpy profiles (the condenser's liquid share chosen for the charge)
  // and wall temperatures. Integrate it to reach the true operating point. Throws
  // std::runtime_error if the property tables do not cover the temperatures.
  [[nodiscard]] std::vector<double> initial_state(double t_out_c, double t_zone_c,
                                                  double charge) const;

  // initial_state() at the outdoor temperature of u and the measured zone temperature (26 degC
  // when not measured), with the nameplate charge.
  bool initial_guess(std::span<const double> u, std::span<const double> y,
                     std::span<double> x) const;

  // An adiabatic line cell (uniform state; smoothed density, see r32_smooth.hpp).
  template <class S>
  struct LineCell {
    S h{}, p{}, rho{}, rho_p{}, rho_h{}, T{};
  };

  // A coil cell: its ends at its pressure and the means over its profile.
  template <class S>
  struct CoilCell {
    S p{};                              // Pa
    S T_in{}, T_out{};                  // K, at the inlet (upstream state) and the outlet
    S h_l{}, h_v{};                     // J/kg, saturation at the cell pressure
    S mass{};                           // kg
    S mass_p{}, mass_in{}, mass_out{};  // its partials: kg/Pa, kg/(J/kg), kg/(J/kg)
    S mass_air{};                       // kg/K, through the air temperature
    // The enthalpy content H = V mean(rho h) [J], as its partials less h_out times the mass's:
    // the capacities of the consistent energy balance (H_x - h_out m_x; see the march).
    S cap_p{}, cap_in{}, cap_out{}, cap_air{};  // m^3, kg, kg, kg J/(kg K)
    S alpha{}, alpha_T{};                       // profile means: W/(m2 K) and W/(m2 K) K
  };

  // Everything one evaluation computes; rhs() and outputs() read what they need.
  template <class S>
  struct Eval {
    S p_cond{}, p_evap{}, dp_cond{}, dp_evap{};
    hp::CompressorFlow<S> comp{};
    S mdot_valve{}, leak{};  // kg/s
    LineCell<S> dl{}, ll{}, sl{};
    std::array<CoilCell<S>, kMaxCells> cond{}, evap{};
    std::array<S, kMaxCells> q_cond{}, q_cond_air{};  // W: into the refrigerant / into the wall
    std::array<S, kMaxCells> q_evap{}, q_evap_air{};
    std::array<S, kMaxCells> hdot_cond{}, hdot_evap{};  // J/(kg s)
    S hdot_dl{}, hdot_ll{}, hdot_sl{};
    S pdot_cond{}, pdot_evap{};
    S t_air{}, t_mass{}, q_int{};
    S cond_htc{}, evap_htc{};     // the two-phase heat-transfer factors (for the end walls)
    S t_air_dot{}, t_mass_dot{};  // K/s, the zone balance
    S g_cond{}, g_evap{};         // W/K, air side of one cell
    S q_zone{};                   // W, heat the indoor unit puts into the zone (negative cooling)
  };

 private:
  [[nodiscard]] ModelLayout make_layout() const;

  // The refrigerant-side state and conditions the pressure solve reads, in its scalar type.
  template <class T>
  struct SideInputs {
    T charge{}, m_cond{};
    T h_dl{}, h_ll{}, h_sl{};                     // J/kg
    std::array<T, kMaxCells> h_cond{}, h_evap{};  // J/kg
    T t_air{};                                    // K, zone air (the evaporator's air inlet)
    T g_cond{}, g_evap{};                         // W/K per cell, air side (UA factors included)
    T comp_flow{}, void_exponent{}, cond_htc{}, evap_htc{}, friction{};  // factors (Factor)
  };
  struct Conditions {
    double speed = 0.0;  // Hz
    double t_out = 0.0;  // K, the condenser's air inlet
  };

  template <class S>
  SideInputs<S> side_inputs(std::span<const S> x, std::span<const double> u) const;
  // The same inputs (or what side_masses() stored) with every scalar mapped by f.
  template <class A, class B, class F>
  void map_inputs(const SideInputs<A>& from, SideInputs<B>& to, F&& f) const;
  template <class A, class B, class F>
  void map_side(const Eval<A>& from, Eval<B>& to, F&& f) const;
  template <class A, class B, class F>
  static void map_cell(const CoilCell<A>& from, CoilCell<B>& to, F&& f);
  // Residuals of the pressure solve, mass of the cells minus the side's mass [kg], at the given
  // pressures. With `e`, the full evaluation (coil cells with their mass partials) is stored.
  template <class T>
  int side_masses(const T& p_cond, const T& p_evap, const SideInputs<T>& in, const Conditions& c,
                  T& r_cond, T& r_evap, Eval<T>* e) const;
  // One coil cell at pressure p: its mass [kg]; with `out`, also its mass partials and profile
  // means (the profile evaluated with Tangent<4, T> in p, h_in, h_out, t_air). `slot` names the
  // cell (condenser k: k, evaporator k: kMaxCells + k) for the local-jet cache below.
  template <class T>
  T coil_cell(const T& p, const T& h_in, const T& h_out, const T& t_air,
              const hp::CellScalars<T>& k, const hp::ProfileOptions& o, double volume,
              std::size_t slot, CoilCell<T>* out) const;
  template <class T>
  T coil_cell_direct(const T& p, const T& h_in, const T& h_out, const T& t_air,
                     const hp::CellScalars<T>& k, const hp::ProfileOptions& o, double volume,
                     CoilCell<T>* out) const;

  // The local jet of a coil cell: everything coil_cell() stores, with its gradient in the cell's
  // seven local inputs (p, h_in, h_out, t_air, g_air, alpha factor, void exponent). A cell
  // depends on the state only through those, so a Jacobian evaluates each cell's profile once,
  // in Dual<7> (its partials then carry second derivatives), and every derivative chunk
  // completes it by the chain rule instead of integrating the profile again in its own, wider
  // scalar. Keyed by the input values: the chunks of one Jacobian share the state's values.
  static constexpr int kCellInputs = 7;
  using CellDual = Dual<kCellInputs>;
  struct CellJet {
    std::array<double, kCellInputs> key{};
    bool valid = false;
    CoilCell<CellDual> cell{};
  };
  // A factor's value: its state, or the parameter when it is not a state.
  template <class S>
  S factor(std::span<const S> x, hp::Factor f) const {
    return L_.factor[f] != hp::kNone ? x[L_.factor[f]] : S(p_.factor[f]);
  }
  // The pressures' move (dpc, dpe) = -J^-1 (rc, re) for the mass residuals (rc, re) and their
  // 2 x 2 Jacobian J in (p_cond, p_evap), row-major; false if J is singular. The Newton step,
  // the first-order start and the implicit-function tangents all solve with it.
  static bool pressure_move(const std::array<double, 4>& J, double rc, double re, double& dpc,
                            double& dpe) {
    const double det = J[0] * J[3] - J[1] * J[2];
    if (!std::isfinite(det) || det == 0.0) return false;
    dpc = -(J[3] * rc - J[1] * re) / det;
    dpe = -(J[0] * re - J[2] * rc) / det;
    return true;
  }
  // Solves the pressures in double precision (warm-started, cached by the inputs). jac: the mass
  // residuals' derivatives in the pressures, taken at the solution itself if jac_at_solution
  // (the implicit-function theorem of a Jacobian needs that; a value does not use jac).
  int solve_pressures(const SideInputs<double>& in, const Conditions& c, double& p_cond,
                      double& p_evap, std::array<double, 4>& jac, bool jac_at_solution) const;
  // The pressure solve's first-order warm start. A right-hand side evaluated with its coil cells
  // (evaluate<double>) leaves the mass residuals' gradients in the refrigerant state (cell,
  // line and side masses, zone air), with the inputs and the pressures they were taken at; the
  // next solve starts Newton at p + dp, dp = -J^-1 (gradient . change of the inputs), instead of
  // at p. The inputs the gradients leave out (factors, air side, compressor speed, the friction
  // profile's shift) count at zero order, as every input did before. Only where Newton starts
  // changes: it still solves to round-off. Measured (stop 53): Newton iterations per solve in
  // estimation_bench --short --filters enkf 2.53 -> 2.14 (the start's error, 1e-3 to 1e-4 of
  // the pressure, falls to 1e-5 to 1e-6: second-order terms and the zero-order inputs leave
  // that, so most solves still take two); heat_pump_bench --short 22.67 -> 21.73 G instructions
  // (callgrind), the long form 8.80 -> 8.42 s; the EnKF's step 36.8 / 36.7 -> 34.4 / 30.7 ms
  // (alternated, a busy host), its ratio to the plain simulation, which gains too, unchanged.
  struct Linearisation {
    bool valid = false;
    SideInputs<double> at{};
    double p_cond = 0.0, p_evap = 0.0;
    std::array<double, 4> jac{};                       // the residuals' 2 x 2 in the pressures
    std::array<double, kMaxCells> cond_h{}, evap_h{};  // kg/(J/kg): d r_side / d h of its cells
    double cond_dl = 0.0, cond_ll = 0.0;               // d r_cond / d h_dl, d h_ll
    double evap_ll = 0.0, evap_sl = 0.0;               // d r_evap / d h_ll, d h_sl
    double evap_air = 0.0;                             // d r_evap / d t_air [kg/K]
  };
  void store_linearisation(const SideInputs<double>& in, const Eval<double>& e,
                           const std::array<double, 4>& jac) const;
  // Where Newton starts for `in`: the stored linearisation's prediction, or false if there is
  // none (or it predicts a move beyond a twentieth of either pressure).
  bool predicted_pressures(const SideInputs<double>& in, double& p_cond, double& p_evap) const;
  template <class S>
  int evaluate(std::span<const S> x, std::span<const double> u, Eval<S>& e) const;
  // The wall at a sensed coil end (hp::End) and what sets it: the refrigerant film's
  // conductance there and the refrigerant's temperature, the air side's conductance and air
  // temperature (W/K per cell, K), and the end cell's mean wall in steady balance with its
  // profile [K]. The local wall in steady balance is (a t_ref + g t_air) / (a + g).
  template <class S>
  struct EndBalance {
    S a{}, t_ref{}, g{}, t_air{}, mean{};
  };
  template <class S>
  EndBalance<S> end_balance(const Eval<S>& e, std::span<const S> x, std::span<const double> u,
                            hp::End end) const;
  template <class S>
  void march_condenser(Eval<S>& e, const std::span<const S> x) const;
  template <class S>
  void march_evaporator(Eval<S>& e, const std::span<const S> x) const;

  hp::Params p_;
  hp::Layout L_;
  std::size_t n_;
  hp::ProfileOptions prof_cond_, prof_evap_;
  // Pressure-solve cache: the inputs it was solved for, and the solution.
  mutable std::vector<double> cache_key_;
  mutable double cache_pc_ = 0.0, cache_pe_ = 0.0;
  mutable std::array<double, 4> cache_jac_{};
  mutable bool cache_valid_ = false;
  mutable bool cache_jac_at_solution_ = false;  // else at the last iterate, a round-off away
  mutable std::vector<CellJet> cell_jets_;      // 2 * kMaxCells slots (see coil_cell)
  mutable Linearisation lin_;
};

}  // namespace hvac_twin::plant

#include "plant_models/heat_pump/heat_pump_eval.hpp"
