// Settling a model's initial guess: integrate it at the first inputs until its fast states are
// consistent with each other, while the states a guess takes from the measured conditions stay
// where they are (StateInfo::held_while_settling: the heat pump's zone air and building mass).
// Without the hold, a 600 s settle of the heat pump cooled its zone by a kelvin below the
// measured temperature, and a filter started there with a tight covariance gate-rejected the
// zone sensor from then on.
//
// Start-up only: allocates (an adapter and an integrator per call); never throws.
#pragma once

#include <span>
#include <string>

#include "plant_models/core/integrator.hpp"
#include "plant_models/core/model.hpp"

namespace hvac_twin::plant {

// Integrates x over `seconds` at the inputs u with every held state's derivative zero. Returns
// false (x unchanged, `error` set when given) if the integration fails.
bool settle(const ContinuousModel& model, std::span<const double> u, double seconds,
            std::span<double> x, std::string* error = nullptr,
            const IntegratorOptions& options = {});

}  // namespace hvac_twin::plant
