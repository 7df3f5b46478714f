// The plant models the daemon can run, by configuration type name. Start-up only (allocates,
// throws std::invalid_argument for an unknown type).
#pragma once

#include <memory>
#include <string_view>
#include <vector>

#include "plant_models/core/model.hpp"
#include "plant_models/core/model_info.hpp"

namespace hvac_twin::plant {

// Every model type with its parameters and layout, for configuration validation.
const std::vector<ModelSchema>& model_schemas();

// The schema of `type`, or nullptr.
const ModelSchema* find_schema(std::string_view type);

// `params` completed with the defaults of every parameter it does not set.
ParameterMap with_defaults(const ModelSchema& schema, const ParameterMap& params);

// A model of `type` with `params` (missing ones take defaults). Values must be validated.
std::unique_ptr<ContinuousModel> create_model(std::string_view type, const ParameterMap& params);

}  // namespace hvac_twin::plant
