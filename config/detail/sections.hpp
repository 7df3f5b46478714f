// Readers for each section of the configuration (internal to config/). Each fills its struct
// from the document, reports every problem to `errors`, and keeps the struct defaults for
// omitted fields.
#pragma once

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "config/config.hpp"
#include "config/detail/reader.hpp"
#include "config/load.hpp"
#include "plant_models/core/model_info.hpp"

namespace hvac_twin::config::detail {

struct RuntimeSection {
  RuntimeConfig config;
  std::optional<double> time_scale;      // set when valid (given or default)
  std::optional<double> hang_timeout_s;  // set when valid (given or default)
};
RuntimeSection read_runtime(const Ref& ref, Errors& errors);

DdsConfig read_dds(const Ref& ref, Errors& errors);

struct ModbusSection {
  ModbusDeviceConfig config;
  std::optional<double> poll_period_s;  // set when valid
  Ref max_registers;                    // the max_registers_per_request value, if given
};
ModbusSection read_modbus(const Ref& ref, Errors& errors);

struct ModelSection {
  ModelConfig config;
  const plant::ModelSchema* schema = nullptr;             // when the type (and its file) is known
  const plant::ModelSchema* catalog_schema = nullptr;     // the type's, from the catalog
  std::shared_ptr<const plant::ModelSchema> file_schema;  // a file's (an FMU's): schema's owner
  std::optional<plant::ModelLayout> layout;  // when the type is known and parameters valid
};
ModelSection read_model(const Ref& ref, Errors& errors, const ModelCatalog& models);

struct PointContext {
  const plant::ModelLayout* layout = nullptr;  // nullptr: signals cannot be checked
  std::string_view model_type;
  std::optional<double> poll_period_s;  // modbus.poll_period_s when valid
};
struct PointsSection {
  std::vector<PointConfig> points;
  std::map<std::string, std::string> measured;  // model output -> first point measuring it
  bool complete = true;                         // every point's role and signal are valid
  std::string two_register_point;               // the first 32-bit point, if any
};
PointsSection read_points(const Ref& ref, Errors& errors, const PointContext& context);

struct EstimatorContext {
  const plant::ModelLayout* layout = nullptr;  // nullptr: names cannot be checked
  std::string_view model_type;
  const PointsSection* points = nullptr;
  std::optional<double> time_scale;
  std::optional<double> hang_timeout_s;
};
EstimatorConfig read_estimator(const Ref& ref, Errors& errors, const EstimatorContext& context);

// What a unit's checks need from outside the unit.
struct UnitContext {
  const ModelCatalog& models;
  std::optional<double> time_scale;      // runtime.time_scale when valid
  std::optional<double> hang_timeout_s;  // runtime.hang_timeout_s when valid
};
UnitConfig read_unit(const Ref& ref, Errors& errors, const UnitContext& context);

// Host names and addresses.
bool is_ipv4_address(std::string_view s);
bool is_host_name(std::string_view s);  // RFC 1123 labels, or an IPv4 address

}  // namespace hvac_twin::config::detail
