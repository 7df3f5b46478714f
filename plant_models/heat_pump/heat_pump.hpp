// R32 vapour-compression heat pump in cooling mode with the zone it serves, written once over
// the scalar type (see plant_models/README.md for every equation, with units).
//
//   compressor -> condenser (N cells) -> liquid line -> expansion valve -> evaporator (N cells)
//   -> suction line -> compressor;   the evaporator's air stream is the zone's air.
//
// Conservative formulation. The high-side refrigerant mass M_cond and the total charge are
// states; the low-side mass is charge - M_cond. Their derivatives are flow differences
// (dM_cond/dt = mdot_comp - mdot_valve, dcharge/dt = -leak), linear in the state, which a BDF
// integrator preserves exactly, so the refrigerant inventory is conserved to round-off. The
// condenser-inlet and evaporator-outlet pressures are algebraic: each is the pressure at which
// the smoothed densities of that side's cells add up to its mass,
//     sum_k V_k rho_s(p_k, h_k) = M,   p_k = the cell's pressure after friction,
// solved by Newton's method (2 x 2, since the friction depends on the compressor flow) to
// round-off; their derivatives with respect to the state follow from the implicit-function
// theorem through one extra Newton step taken in the dual-number scalar. Within each side the
// cell enthalpies follow the energy balances, and the internal mass flows follow from the cell
// mass balances with one common dp/dt that makes the last cell's outflow equal the downstream
// component's flow (a marching solution, affine in dp/dt).
//
// A model instance caches the last pressure solution (warm start, and reuse across the
// derivative chunks of one Jacobian), so it serves one thread; AdModel::clone() makes another.
// Evaluation never allocates and never throws; a state without a pressure solution, or outside
// the property tables, is a recoverable error (status > 0).
#pragma once

#include <array>
#include <memory>
#include <span>
#include <vector>

#include "plant_models/core/model.hpp"
#include "plant_models/core/model_info.hpp"
#include "plant_models/heat_pump/hp_components.hpp"
#include "plant_models/heat_pump/hp_layout.hpp"
#include "plant_models/heat_pump/hp_params.hpp"

namespace hvac_twin::plant {

class HeatPumpR32 {
 public:
  static constexpr const char* kType = "heat_pump_r32";
  static constexpr std::size_t kMaxCells = 40;

  explicit HeatPumpR32(const hp::Params& params);
  explicit HeatPumpR32(const ParameterMap& values) : HeatPumpR32(hp::params_from_map(values)) {}
  // Copies have their own caches (a model instance serves one thread).
  HeatPumpR32(const HeatPumpR32& other);
  HeatPumpR32& operator=(const HeatPumpR32&) = delete;
  HeatPumpR32(HeatPumpR32&&) noexcept = default;
  ~HeatPumpR32();

  [[nodiscard]] static std::vector<ParameterInfo> parameter_info() { return hp::parameter_info(); }
  [[nodiscard]] ModelLayout layout() const { return make_layout(); }
  [[nodiscard]] const hp::Params& params() const { return p_; }
  [[nodiscard]] const hp::Layout& slots() const { return L_; }

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

  // One cell of refrigerant after the pressure solve.
  template <class S>
  struct Cell {
    S h{}, p{}, rho{}, rho_p{}, rho_h{}, T{}, quality{};
  };

  // Everything one evaluation computes; rhs() and outputs() read what they need.
  template <class S>
  struct Eval {
    S p_cond{}, p_evap{}, dp_cond{}, dp_evap{};
    hp::CompressorFlow<S> comp{};
    S mdot_valve{}, leak{};                             // kg/s
    std::array<Cell<S>, kMaxCells + 1> cond{}, evap{};  // [N] is the liquid / suction line
    std::array<S, kMaxCells> q_cond{}, q_cond_air{};    // W: into the refrigerant / into wall
    std::array<S, kMaxCells> q_evap{}, q_evap_air{};
    std::array<S, kMaxCells + 1> hdot_cond{}, hdot_evap{};  // J/(kg s)
    S pdot_cond{}, pdot_evap{};
    S t_air{}, t_mass{}, q_int{}, fouling{};
    S q_zone{};  // W, heat the indoor unit puts into the zone (negative when cooling)
  };

 private:
  [[nodiscard]] ModelLayout make_layout() const;

  // Inputs of the pressure solve, converted to the solve's scalar type.
  template <class T>
  struct SideInputs {
    T charge{}, m_cond{};
    std::array<T, kMaxCells + 1> h_cond{}, h_evap{};  // J/kg; [N] the line cell
  };
  template <class T>
  int fill_sides(const T& p_cond, const T& p_evap, const SideInputs<T>& in, double speed,
                 Eval<T>& e, T& r_cond, T& r_evap) const;
  // Solves the pressures in double precision (warm-started, cached by state and speed).
  int solve_pressures(const SideInputs<double>& in, double speed, double& p_cond, double& p_evap,
                      std::array<double, 4>& jac) const;
  template <class S>
  int evaluate(std::span<const S> x, std::span<const double> u, Eval<S>& e) const;
  template <class S>
  void promote(const Eval<double>& from, Eval<S>& to) const;
  template <class S>
  void chain_pressures(const Eval<Dual<2>>& at_p, const S& dpc, const S& dpe, Eval<S>& e) const;
  template <class S>
  void march(std::span<Cell<S>> cells, std::span<const S> q, double v_cell, double v_line,
             const S& mdot_in, const S& h_in, const S& mdot_out, std::span<S> hdot, S& pdot) const;

  hp::Params p_;
  hp::Layout L_;
  std::size_t n_;
  // Pressure-solve cache: the inputs it was solved for, and the solution.
  mutable std::vector<double> cache_key_;
  mutable double cache_pc_ = 0.0, cache_pe_ = 0.0;
  mutable std::array<double, 4> cache_jac_{};
  mutable bool cache_valid_ = false;
  // The Newton solve's last evaluation, seeded in (p_cond, p_evap): the cells' pressure
  // derivatives for chain_pressures().
  std::unique_ptr<Eval<Dual<2>>> pressure_eval_ = std::make_unique<Eval<Dual<2>>>();
};

}  // namespace hvac_twin::plant

#include "plant_models/heat_pump/heat_pump_eval.hpp"
