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
    s.layout = [layout = fmu_layout(d)](const plant::ParameterMap&) { return layout; };
    return s;
  };
  return schema;
}

}  // namespace hvac_twin::fmi
