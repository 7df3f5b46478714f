// The model types the daemon and hvac-twin-replay run, and a unit's model made from its
// configuration: a built-in model of the plant catalog, or (type "fmu") an FMI 2.0 Model
// Exchange FMU unpacked into a directory of the caller's and loaded into the process.
// Start-up only (allocates, throws).
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <utility>

#include "config/config.hpp"
#include "config/load.hpp"
#include "plant_models/core/model.hpp"

namespace hvac_twin::runtime {

// plant::model_schemas() and "fmu".
const config::ModelCatalog& model_catalog();

// A unit's model file (an FMU) that passed validation but cannot be loaded or instantiated (its
// binary refuses the description's GUID, dlopen fails, ...): a configuration error, at `pointer`.
class UnitModelError : public std::runtime_error {
 public:
  UnitModelError(std::string pointer, const std::string& what)
      : std::runtime_error(what), pointer_(std::move(pointer)) {}
  [[nodiscard]] const std::string& pointer() const { return pointer_; }

 private:
  std::string pointer_;
};

struct UnitModel {
  std::unique_ptr<plant::ContinuousModel> model;
  std::string origin;  // for the log: "built-in zone_rc", "FMU <path> (...Jacobians by ...)"
};

// `fmu_directory`: where an FMU is unpacked (the daemon's <state_directory>/fmu/<unit>; it must
// be missing, empty or an earlier unpack). `pointer`: the model's JSON pointer, for errors.
// Throws UnitModelError when the FMU cannot be loaded.
UnitModel make_unit_model(const config::ModelConfig& model, const std::string& fmu_directory,
                          const std::string& pointer = "/units/0/model");

// A private directory for an offline tool's FMU: mkdtemp(3) under $TMPDIR (or /tmp), mode 0700,
// removed with its contents when destroyed.
class PrivateDirectory {
 public:
  PrivateDirectory();
  ~PrivateDirectory();
  PrivateDirectory(const PrivateDirectory&) = delete;
  PrivateDirectory& operator=(const PrivateDirectory&) = delete;
  [[nodiscard]] const std::string& path() const { return path_; }

 private:
  std::string path_;
};

}  // namespace hvac_twin::runtime
