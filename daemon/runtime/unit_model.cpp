#include "daemon/runtime/unit_model.hpp"

#include <cstdlib>
#include <filesystem>
#include <stdexcept>
#include <system_error>
#include <vector>

#include "io/fmi/import/fmu_model.hpp"
#include "io/fmi/import/fmu_schema.hpp"
#include "plant_models/catalog.hpp"

namespace hvac_twin::runtime {

const config::ModelCatalog& model_catalog() {
  static const config::ModelCatalog catalog = [] {
    config::ModelCatalog all = plant::model_schemas();
    all.push_back(fmi::fmu_schema());
    return all;
  }();
  return catalog;
}

UnitModel make_unit_model(const config::ModelConfig& model, const std::string& fmu_directory,
                          const std::string& pointer) {
  if (model.type != fmi::kFmuModelType)
    return {plant::create_model(model.type, model.parameters), "built-in " + model.type};
  try {
    const auto library = fmi::load_fmu(model.file, fmu_directory);
    auto fmu =
        std::make_unique<fmi::FmuModel>(library, fmi::FmuOptions{.parameters = model.parameters});
    const bool exact = fmu->jacobian_method() == fmi::JacobianMethod::kDirectionalDerivative;
    std::string origin =
        "FMU " + model.file + " (model " + fmi::description_of(*library).model_name +
        ", unpacked in " + fmu_directory + "; Jacobians by " +
        (exact ? "fmi2GetDirectionalDerivative"
               : "central differences: the FMU provides no directional derivatives") +
        ")";
    return {std::move(fmu), std::move(origin)};
  } catch (const fmi::FmuError& e) {
    throw UnitModelError(pointer + "/fmu", e.what());
  }
}

PrivateDirectory::PrivateDirectory() {
  const char* tmp = std::getenv("TMPDIR");
  std::string pattern =
      std::string(tmp != nullptr && *tmp != '\0' ? tmp : "/tmp") + "/hvac-twin-fmu-XXXXXX";
  std::vector<char> buffer(pattern.begin(), pattern.end());
  buffer.push_back('\0');
  if (::mkdtemp(buffer.data()) == nullptr)
    throw std::system_error(errno, std::generic_category(), "mkdtemp " + pattern);
  path_ = buffer.data();
}

PrivateDirectory::~PrivateDirectory() {
  std::error_code ec;
  std::filesystem::remove_all(path_, ec);
}

}  // namespace hvac_twin::runtime
