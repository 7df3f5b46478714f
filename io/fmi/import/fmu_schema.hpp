// The model type "fmu" for configuration validation: its schema reads a named FMU's description
// (without unpacking or loading it) and gives the FMU's Real parameters and its layout, so the
// points, estimator and leak sections are checked against the FMU's own variables.
#pragma once

#include "plant_models/core/model_info.hpp"

namespace hvac_twin::fmi {

inline constexpr const char* kFmuModelType = "fmu";

plant::ModelSchema fmu_schema();

}  // namespace hvac_twin::fmi
