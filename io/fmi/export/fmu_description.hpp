// What an exported FMU declares: the variables of a built-in model, their value references, and
// the modelDescription.xml text, from the same layout the daemon runs (one source). The FMU's
// shared library and the packaging tool both compute it, so the GUID the library checks at
// fmi2Instantiate is the one the archive's description carries: a hash of the description text.
//
// Value references, in the order of ModelVariables (index = reference + 1):
//   states [0, n), derivatives [n, 2n), inputs, outputs, tunable parameters, structural
//   parameters (constants: the layout was built with them). Start-up only (allocates).
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "plant_models/core/model_info.hpp"

namespace hvac_twin::fmi {

struct ExportedModel {
  std::string type;  // the modelIdentifier, the shared library's name
  std::string description;
  plant::ModelLayout layout;
  std::vector<plant::ParameterInfo> tunable;     // settable before initialisation ends
  std::vector<plant::ParameterInfo> structural;  // fixed when built (they shape the layout); their
                                                 // default_value is the value built with
  std::string guid;
  std::string xml;

  [[nodiscard]] std::size_t n() const { return layout.states.size(); }
  [[nodiscard]] unsigned state_ref(std::size_t i) const { return ref(i); }
  [[nodiscard]] unsigned derivative_ref(std::size_t i) const { return ref(n() + i); }
  [[nodiscard]] unsigned input_ref(std::size_t i) const { return ref(2 * n() + i); }
  [[nodiscard]] unsigned output_ref(std::size_t i) const {
    return ref(2 * n() + layout.inputs.size() + i);
  }
  [[nodiscard]] unsigned parameter_ref(std::size_t i) const {
    return ref(2 * n() + layout.inputs.size() + layout.outputs.size() + i);
  }

 private:
  static unsigned ref(std::size_t i) { return static_cast<unsigned>(i); }
};

// The built-in model `type`, described: its structural (integer) parameters at their defaults
// except those `structure` sets ("name=value,name=value"; the build gives the heat pump the
// demo's), the others tunable at their defaults. Throws std::invalid_argument for an unknown type
// or a structure that is not the type's structural parameters.
ExportedModel describe_builtin(std::string_view type, std::string_view structure = {});

}  // namespace hvac_twin::fmi
