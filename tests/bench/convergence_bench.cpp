// How the heat-pump model's steady answers depend on its cell count (issue: the model converges).
//
//   convergence_bench [--short]
//
// At three operating points (part load in mild weather, nominal, full load in hot weather; the
// zone held at its temperature, 0.5 kg of R32) the model is run to steady state at several cell
// counts and compared with the continuous reference (tests/support/heat_pump_steady.hpp: the
// coils' steady profiles integrated along the tube, no cells at all) and, as a cross-check,
// with the Richardson extrapolation of the two finest cell counts. Printed per cell count:
// subcooling, superheat, discharge and suction pressure, the four coil-end wall temperatures,
// both heat flows, and the charge at which the model reproduces the reference's subcooling
// (error in % of the 0.5 kg nameplate). The aims at the default cell count: subcooling,
// superheat and wall temperatures within 0.3 K, charge within 1 % of the nameplate, heat flows
// within 1 %; the program says whether each is met.
// Then the benchmark truth (Smith void fraction, the variant two-phase heat transfer correlations,
// friction ~ mdot^1.75 distributed by specific volume): its answers at 10-40 cells, to show the
// cell count it runs at is converged too (Richardson of 30 and 40 cells as its reference).
// Then the dynamic answers (heat_pump_steady.hpp, model_transient: the valve hunting +-5 % for
// 10 minutes, then a +8 Hz speed step) at --point or the nominal point, for the filter's model
// and the truth: each measured point's motion against the finest cell count, RMS and largest,
// with the sensors' noise for scale; aim: RMS within the noise at 12 cells. Steady convergence
// does not imply it: with the lag-free end formula (--set end_walls=0) the condenser-inlet wall's
// motion at 12 cells is 2.6x its sensor's noise off at the flooded point; with the end walls,
// 0.4x (README, "The charge's cell-count dependence").
// --short: the nominal point only, fewer cell counts (CI). --point SPEED,VALVE,T_OUT,T_ZONE: that
// operating point instead of the three (e.g. 20,0.27,35,27: the 20 Hz minimum with a flooded
// evaporator, where estimation_bench's hour ends; 12 cells 0.36 % of the nameplate off, met).
// --set PARAM=V: a model parameter, for the filter's model and the truth alike (e.g. end_walls=1).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "tests/simulator/truth_model.hpp"
#include "tests/support/heat_pump_steady.hpp"

using namespace hvac_twin;
using test::OperatingPoint;
using test::SteadyAnswer;

namespace {

constexpr int kDefaultCells = 12;  // hp_params.hpp
constexpr double kNameplate = 0.5;

void print_header() {
  std::printf("  %-10s %6s %6s %8s %7s %6s %6s %6s %6s %7s %7s %8s\n", "cells", "subc K", "sh K",
              "p_dis kPa", "p_suc", "Tw_ci", "Tw_co", "Tw_ei", "Tw_eo", "Q_c W", "Q_e W",
              "charge %");
}

void print_row(const std::string& label, const SteadyAnswer& a, double charge_error_pct) {
  std::printf("  %-10s %6.2f %6.2f %8.1f %7.1f %6.2f %6.2f %6.2f %6.2f %7.1f %7.1f", label.c_str(),
              a.subcooling, a.superheat, a.p_discharge / 1e3, a.p_suction / 1e3, a.tw_cond_in,
              a.tw_cond_out, a.tw_evap_in, a.tw_evap_out, a.q_cond, a.q_evap);
  if (std::isfinite(charge_error_pct)) std::printf(" %+8.2f", charge_error_pct);
  std::printf("\n");
}

// Largest errors against the reference: temperatures [K], heat flows [relative], pressures
// [relative].
struct Errors {
  double temperature = 0, heat = 0, pressure = 0;
};

Errors errors(const SteadyAnswer& a, const SteadyAnswer& r) {
  Errors e;
  for (const auto& [x, y] : {std::pair{a.subcooling, r.subcooling},
                             {a.superheat, r.superheat},
                             {a.tw_cond_in, r.tw_cond_in},
                             {a.tw_cond_out, r.tw_cond_out},
                             {a.tw_evap_in, r.tw_evap_in},
                             {a.tw_evap_out, r.tw_evap_out}})
    e.temperature = std::max(e.temperature, std::abs(x - y));
  e.heat = std::max(std::abs(a.q_cond / r.q_cond - 1.0), std::abs(a.q_evap / r.q_evap - 1.0));
  e.pressure = std::max(std::abs(a.p_discharge / r.p_discharge - 1.0),
                        std::abs(a.p_suction / r.p_suction - 1.0));
  return e;
}

SteadyAnswer richardson(const SteadyAnswer& coarse, const SteadyAnswer& fine, double ratio) {
  // Second order: f = f_fine + (f_fine - f_coarse) / (ratio^2 - 1).
  const double k = 1.0 / (ratio * ratio - 1.0);
  const auto r = [k](double c, double f) { return f + (f - c) * k; };
  SteadyAnswer s;
  s.subcooling = r(coarse.subcooling, fine.subcooling);
  s.superheat = r(coarse.superheat, fine.superheat);
  s.p_discharge = r(coarse.p_discharge, fine.p_discharge);
  s.p_suction = r(coarse.p_suction, fine.p_suction);
  s.tw_cond_in = r(coarse.tw_cond_in, fine.tw_cond_in);
  s.tw_cond_out = r(coarse.tw_cond_out, fine.tw_cond_out);
  s.tw_evap_in = r(coarse.tw_evap_in, fine.tw_evap_in);
  s.tw_evap_out = r(coarse.tw_evap_out, fine.tw_evap_out);
  s.q_cond = r(coarse.q_cond, fine.q_cond);
  s.q_evap = r(coarse.q_evap, fine.q_evap);
  return s;
}

// The points' motion in the scripted transient (heat_pump_steady.hpp, model_transient) at each
// of `cells`, against the last (the finest): per point, the RMS and the largest error in its
// change from its own steady state, so the steady offsets above are left out. Pressures in kPa,
// temperatures in K, with the sensors' noise (estimation_bench: 0.5 % of the reading, 0.2 K)
// for scale.
bool dynamic_section(const plant::ParameterMap& params, const char* label, const OperatingPoint& op,
                     const std::vector<int>& cells) {
  std::vector<std::vector<test::MeasuredPoints>> runs;
  const auto t0 = std::chrono::steady_clock::now();
  for (const int n : cells)
    runs.push_back(test::model_transient(params, n, op, kNameplate));
  const auto& ref = runs.back();
  std::printf(
      "\n%s, %s (valve %.3f): the points' motion in the transient against %d cells, RMS "
      "/ largest (%.1f s)\n",
      label, op.name, op.valve, cells.back(),
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  std::printf("  %-12s %13s %13s %13s %13s %13s %13s\n", "cells", "p_suc kPa", "p_dis kPa",
              "Tw_ci K", "Tw_co K", "Tw_ei K", "Tw_eo K");
  constexpr double kScale[6] = {1e-3, 1e-3, 1, 1, 1, 1};
  const double sigma[6] = {5e-3 * ref[0][0], 5e-3 * ref[0][1], 0.2, 0.2, 0.2, 0.2};
  constexpr const char* kName[6] = {"p_suc", "p_dis", "Tw_ci", "Tw_co", "Tw_ei", "Tw_eo"};
  std::string beyond;  // the points whose motion's RMS error exceeds the sensor's noise
  for (std::size_t r = 0; r + 1 < runs.size(); ++r) {
    std::printf("  %-12d", cells[r]);
    for (std::size_t j = 0; j < 6; ++j) {
      const test::MotionError m = test::motion_error(runs[r], ref, j);
      std::printf("  %5.2f / %5.2f", kScale[j] * m.rms, kScale[j] * m.largest);
      if (cells[r] == kDefaultCells && m.rms > sigma[j])
        beyond += std::string(beyond.empty() ? "" : ", ") + kName[j];
    }
    std::printf("\n");
  }
  std::printf("  %-12s ", "sensor sigma");
  for (std::size_t j = 0; j < 6; ++j)
    std::printf("  %13.2f", kScale[j] * sigma[j]);
  std::printf("\n");
  if (std::find(cells.begin(), cells.end() - 1, kDefaultCells) != cells.end() - 1)
    std::printf("  at %d cells, the motion's RMS error within the sensor's noise (aim): %s%s\n",
                kDefaultCells, beyond.empty() ? "met at every point" : "MISSED at ",
                beyond.c_str());
  return beyond.empty();
}

}  // namespace

int main(int argc, char** argv) {
  bool short_form = false;
  std::optional<OperatingPoint> point;
  std::string point_name;      // --point's, as the three points are named
  plant::ParameterMap filter;  // the daemon's default model, with --set's changes
  plant::ParameterMap truth = sim::truth_closures();
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--short") == 0) {
      short_form = true;
    } else if (std::strcmp(argv[i], "--point") == 0 && i + 1 < argc) {
      OperatingPoint op{"", 0.0, 0.0, 0.0, 0.0};
      char end = 0;
      if (std::sscanf(argv[++i], "%lf,%lf,%lf,%lf%c", &op.speed, &op.valve, &op.t_out, &op.t_zone,
                      &end) != 4 ||
          !(op.speed > 0.0) || !(op.valve > 0.0 && op.valve <= 1.0)) {
        std::fprintf(stderr,
                     "convergence_bench: --point wants SPEED_HZ,VALVE,T_OUT_C,T_ZONE_C with a "
                     "speed above 0 and a valve opening in (0, 1], got \"%s\"\n",
                     argv[i]);
        return 2;
      }
      char name[96];
      std::snprintf(name, sizeof name, "%.0f Hz, %.0f/%.0f degC", op.speed, op.t_out, op.t_zone);
      point_name = name;
      point = op;
    } else if (std::strcmp(argv[i], "--set") == 0 && i + 1 < argc) {
      const std::string kv = argv[++i];
      const std::size_t eq = kv.find('=');
      char* end = nullptr;
      const double v =
          eq == std::string::npos ? std::nan("") : std::strtod(kv.c_str() + eq + 1, &end);
      if (eq == std::string::npos || eq == 0 || end == kv.c_str() + eq + 1 || *end != '\0' ||
          !std::isfinite(v)) {
        std::fprintf(stderr, "convergence_bench: --set wants PARAM=NUMBER, got \"%s\"\n",
                     kv.c_str());
        return 2;
      }
      filter[kv.substr(0, eq)] = truth[kv.substr(0, eq)] = v;
    } else {
      std::fprintf(stderr,
                   "usage: convergence_bench [--short] [--point SPEED,VALVE,T_OUT,T_ZONE] "
                   "[--set PARAM=V]...\n");
      return 2;
    }
  }
  const std::vector<int> cells =
      short_form ? std::vector<int>{6, 12, 20} : std::vector<int>{4, 6, 8, 10, 12, 16, 20, 40};
  bool all_met = true;
  std::printf("Convergence of heat_pump_r32 in its cell count (filter model, 0.5 kg R32)\n");
  std::vector<OperatingPoint> points(test::kConvergencePoints.begin(),
                                     test::kConvergencePoints.end());
  if (point) {
    point->name = point_name.c_str();
    points = {*point};
  }
  for (const OperatingPoint& op : points) {
    if (short_form && !point && op.speed != 50.0) continue;
    const auto t0 = std::chrono::steady_clock::now();
    const SteadyAnswer ref = test::continuous_steady(filter, op, kNameplate);
    std::printf("\n%s (valve %.3f)\n", op.name, op.valve);
    print_header();
    print_row("continuous", ref, NAN);
    std::vector<SteadyAnswer> at;
    for (const int n : cells) {
      at.push_back(test::model_steady(filter, n, op, kNameplate));
      const double m = test::model_charge_for_subcooling(filter, n, op, ref.subcooling);
      print_row(std::to_string(n), at.back(), 100.0 * (m - kNameplate) / kNameplate);
      if (n == kDefaultCells) {
        const Errors e = errors(at.back(), ref);
        const bool met =
            e.temperature <= 0.3 && e.heat <= 0.01 && std::abs(m - kNameplate) <= 0.01 * kNameplate;
        all_met = all_met && met;
        std::printf(
            "  %d cells: largest error %.3f K (aim 0.3), heat flows %.2f %% (aim 1), "
            "pressures %.2f %%, charge %.2f %% of nameplate (aim 1): %s\n",
            n, e.temperature, 100.0 * e.heat, 100.0 * e.pressure,
            100.0 * std::abs(m - kNameplate) / kNameplate, met ? "met" : "MISSED");
      }
    }
    const double ratio = static_cast<double>(cells.back()) / cells[cells.size() - 2];
    const SteadyAnswer rich = richardson(at[at.size() - 2], at.back(), ratio);
    print_row("Richardson", rich, NAN);
    const Errors cross = errors(rich, ref);
    std::printf("  Richardson vs continuous: %.3f K, heat %.3f %%, pressure %.3f %%  (%.1f s)\n",
                cross.temperature, 100.0 * cross.heat, 100.0 * cross.pressure,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }

  // The benchmark truth's own convergence at its cell count.
  const std::vector<int> truth_cells =
      short_form ? std::vector<int>{20, 40} : std::vector<int>{10, 20, 30, 40};
  std::printf(
      "\nBenchmark truth closures (Smith slip, the variant two-phase htc with dryout at 0.75, "
      "friction ~ mdot^1.75 by specific volume), %s\n",
      test::kConvergencePoints[1].name);
  print_header();
  std::vector<SteadyAnswer> tr;
  for (const int n : truth_cells) {
    tr.push_back(test::model_steady(truth, n, test::kConvergencePoints[1], kNameplate));
    print_row(std::to_string(n), tr.back(), NAN);
  }
  const double ratio =
      static_cast<double>(truth_cells.back()) / truth_cells[truth_cells.size() - 2];
  const SteadyAnswer rich = richardson(tr[tr.size() - 2], tr.back(), ratio);
  print_row("Richardson", rich, NAN);
  const auto at_truth = std::find(truth_cells.begin(), truth_cells.end(), sim::kTruthCells);
  if (at_truth != truth_cells.end()) {
    const Errors e = errors(tr[static_cast<std::size_t>(at_truth - truth_cells.begin())], rich);
    std::printf("  truth at %d cells vs Richardson: %.3f K, heat %.3f %%, pressure %.3f %%\n",
                sim::kTruthCells, e.temperature, 100.0 * e.heat, 100.0 * e.pressure);
  }
  // The dynamic answers, at --point or the nominal point: the default model and the truth.
  const OperatingPoint& moving = point ? *point : test::kConvergencePoints[1];
  std::printf(
      "\nTransient from steady state: the valve +-5 %% in a 50 s square wave for 10 min, then "
      "the compressor +8 Hz for 10 min\n");
  all_met = dynamic_section(
                filter, "filter model", moving,
                short_form ? std::vector<int>{12, 20, 40} : std::vector<int>{6, 12, 20, 30, 40}) &&
            all_met;
  dynamic_section(truth, "benchmark truth", moving, {20, 40});
  if (point)
    std::printf("\naims at %d cells at %s (valve %.3f): %s\n", kDefaultCells, point->name,
                point->valve, all_met ? "all met" : "MISSED (see above)");
  else
    std::printf("\naims at %d cells: %s\n", kDefaultCells,
                all_met ? "all met" : "MISSED (see above)");
  return 0;
}
