// The plant the simulator and the benchmarks treat as the truth: heat_pump_r32 converged (more
// cells than the filter's model) and with closures a real unit has that the filter's model does
// not share: Smith's separated-flow void fraction instead of Zivi's slip; other two-phase heat
// transfer correlations (condensing linear in quality instead of x^0.75, nucleate-dominated
// boiling, dryout from a quality of 0.75 instead of 0.8); friction growing as mdot^1.75 and
// distributed along each coil by the cells' specific volume instead of mdot^2, uniformly.
// convergence_bench shows these answers are converged at kTruthCells.
#pragma once

#include "plant_models/core/model_info.hpp"

namespace hvac_twin::sim {

inline constexpr int kTruthCells = 20;

// The truth's closures, over the unit's configured parameters.
inline plant::ParameterMap truth_closures(plant::ParameterMap params = {}) {
  params["cells"] = kTruthCells;
  params["void_fraction"] = 2;
  params["two_phase_htc"] = 2;
  params["dryout_quality"] = 0.75;
  params["dp_exponent"] = 1.75;
  params["dp_distribution"] = 1;
  return params;
}

}  // namespace hvac_twin::sim
