// The parts of an FMI 2.0 modelDescription.xml that a Model Exchange import needs, parsed and
// checked (pugixml). Start-up only; throws FmuError naming the file and what is wrong.
#pragma once

#include <cstddef>
#include <limits>
#include <map>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace hvac_twin::fmi {

// Every failure to load, check or instantiate an FMU.
class FmuError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct FmuVariable {
  std::string name;
  unsigned ref = 0;
  std::string causality = "local";
  std::string variability = "continuous";
  std::string type;  // "Real", "Integer", "Boolean", "String", "Enumeration"
  std::string unit;
  std::string description;
  double start = std::numeric_limits<double>::quiet_NaN();
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  double nominal = 1.0;
  long derivative_of = -1;  // index (0-based) of the state this variable is the derivative of
  // The attributes of its hvac-twin annotation (<State> or <Output>, io/fmi/annotations.hpp).
  std::map<std::string, std::string> tool;
};

// A constraint of the hvac-twin annotations, its terms by variable name.
struct ToolConstraint {
  std::string name;
  bool over_outputs = false;
  double bound = 0.0;
  std::string while_input;  // empty: always
  double while_above = 0.0;
  std::vector<std::pair<std::string, double>> terms;
};

struct ModelDescription {
  std::string model_name;
  std::string guid;
  std::string model_identifier;  // of <ModelExchange>: the shared library's name
  bool provides_directional_derivative = false;
  std::vector<FmuVariable> variables;  // in ModelVariables order
  std::vector<std::size_t> states;     // indices into variables, in <Derivatives> order
  std::vector<std::size_t> derivatives;
  std::vector<std::size_t> inputs;
  std::vector<std::size_t> outputs;         // in <Outputs> order
  std::vector<std::size_t> parameters;      // causality "parameter", Real
  std::vector<ToolConstraint> constraints;  // from the hvac-twin vendor annotations

  [[nodiscard]] const FmuVariable* find(const std::string& name) const {
    for (const auto& v : variables)
      if (v.name == name) return &v;
    return nullptr;
  }
};

// Parses the text of a modelDescription.xml; `source` names it in errors. Refuses what the
// import does not support: another FMI version, no <ModelExchange>, event indicators, discrete
// states, non-Real inputs or outputs.
ModelDescription parse_model_description(const std::string& text, const std::string& source);

}  // namespace hvac_twin::fmi
