// What configuration validation needs to know about the models it may be asked to configure:
// each model type's parameters, and the layout (states, inputs, outputs) those parameters give.
// The runtime fills this from the plant-model catalog and passes it in, so the config library
// does not link model code.
#pragma once

#include <functional>
#include <map>
#include <string>
#include <vector>

#include "plant_models/core/model_info.hpp"

namespace hvac_twin::config {

struct ModelSchema {
  std::string type;
  std::string description;
  std::vector<plant::ParameterInfo> parameters;
  // The layout for a full parameter set (defaults filled in, every value inside its range).
  // Structural parameters (a cell count) change it. Must not throw for such a set.
  std::function<plant::ModelLayout(const std::map<std::string, double>&)> layout;
};

using ModelCatalog = std::vector<ModelSchema>;

}  // namespace hvac_twin::config
