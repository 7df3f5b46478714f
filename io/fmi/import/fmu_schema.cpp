#include "io/fmi/import/fmu_schema.hpp"

#include <cmath>

#include "io/fmi/import/fmu_archive.hpp"
#include "io/fmi/import/fmu_model.hpp"

namespace hvac_twin::fmi {

plant::ModelSchema fmu_schema() {
  plant::ModelSchema schema;
  schema.type = kFmuModelType;
  schema.description =
      "an FMI 2.0 Model Exchange FMU with a linux64 binary (\"fmu\": its absolute path)";
  schema.from_file = [](const std::string& path) {
    const ModelDescription d = read_fmu_description(path);
    plant::ModelSchema s;
    s.type = kFmuModelType;
    s.description = "FMU " + d.model_name + " (" + path + ")";
    for (std::size_t i : d.parameters) {
      const FmuVariable& v = d.variables[i];
      s.parameters.push_back({v.name, v.unit.empty() ? "1" : v.unit,
                              std::isnan(v.start) ? 0.0 : v.start, v.min, v.max, false,
                              v.description});
    }
    for (std::size_t i : d.inputs) {
      const std::string& input = d.variables[i].name;
      s.parameters.push_back({kAugmentPrefix + input, "1", 0.0, 0.0, 1.0, true,
                              "1: estimate an unknown additive disturbance of input " + input +
                                  " as the random-walk state " + input + kDisturbanceSuffix});
    }
    s.layout = [d](const plant::ParameterMap& params) { return fmu_layout(d, params); };
    return s;
  };
  return schema;
}

}  // namespace hvac_twin::fmi
