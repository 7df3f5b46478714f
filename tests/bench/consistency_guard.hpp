// estimation_bench --require-consistency: the floor under issue 12's aims that CI holds.
//
// The aims (NIS and NEES in their 95 % chi-square bands, 90-98 % of errors within 2 sigma) are
// printed as met or MISSED and are not all met (README, "Evidence"); a test on them would be red
// or would be loosened until it said nothing. This guard is what must never come back: the state
// the issue was filed against (NIS 7, NEES 170x, the charge 16-24 sigma off, a sensor gated out
// in 87-100 % of cycles, the sensor noise inflated five-fold to hide it), in either direction
// (sigma far too small, or far too wide). On the two normal truths (nominal, mismatched):
//  - overall NIS within 2x of its expected 1 ([0.5, 2]: the aim for mismatched truths);
//  - each measured point's NIS within 3x ([1/3, 3]: sigma off by more than sqrt(3));
//  - no point gate-rejected in more than 5 % of its cycles (the aim itself);
//  - each virtual sensor and the charge within 2 sigma at least 80 % of the time;
//  - the charge's mean error within 4 % of the nameplate (aim 2 %; the EnKF's half hour +3.4 %).
// On the biased-sensor truth the filter cannot know the sensor is off (its offset state is
// opt-in): only the overall NIS within 2x. Header-only; benchmarks only.
#pragma once

#include <cstdio>
#include <string>
#include <vector>

#include "plant_models/heat_pump/hp_layout.hpp"
#include "tests/bench/estimation_run.hpp"
#include "tests/bench/heat_pump_scenario.hpp"

namespace hvac_twin::bench {

struct GuardLimits {
  double nis_lo = 0.5, nis_hi = 2.0;  // overall
  double point_nis_lo = 1.0 / 3.0, point_nis_hi = 3.0;
  double max_gated = 0.05;
  double min_within_2sigma = 0.80;
  double max_charge_error = 0.04 * 0.5;  // kg: 4 % of the 0.5 kg nameplate
};

// Prints one "guard:" line per violation; true when there is none.
inline bool consistency_guard(TruthKind truth, const std::vector<FilterRun>& runs,
                              const GuardLimits& g = {}) {
  const bool normal = truth != TruthKind::kSensorBias;
  bool ok = true;
  // Each check a closed interval; a NaN is outside every one.
  const auto check = [&](const FilterRun& r, const char* what, const std::string& name, double v,
                         double lo, double hi) {
    if (v >= lo && v <= hi) return;
    std::printf("guard: %s, %s: %s %s = %.3f outside [%.3f, %.3f]\n", truth_name(truth),
                r.name.c_str(), what, name.c_str(), v, lo, hi);
    ok = false;
  };
  for (const auto& r : runs) {
    check(r, "NIS", "overall", r.nis(), normal ? g.nis_lo : 0.0, g.nis_hi);
    if (!normal) continue;
    for (const auto& s : r.sensors) {
      check(r, "NIS of", s.name(), s.nis(), g.point_nis_lo, g.point_nis_hi);
      check(r, "gate-rejected share of", s.name(), s.rejected_share(), 0.0, g.max_gated);
    }
    for (const auto& q : r.outputs)
      check(r, "share within 2 sigma of", q.name(), q.within_2sigma(), g.min_within_2sigma, 1.0);
    check(r, "mean error [kg] of", "charge", r.output(plant::hp::kCharge).bias(),
          -g.max_charge_error, g.max_charge_error);
  }
  std::printf("consistency guard (%s): %s\n", truth_name(truth), ok ? "held" : "FAILED");
  return ok;
}

}  // namespace hvac_twin::bench
