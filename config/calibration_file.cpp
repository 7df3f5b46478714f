#include "config/calibration_file.hpp"

#include <cmath>

namespace hvac_twin::config {

namespace {
constexpr const char* kFormat = "hvac-twin calibration";
constexpr int kVersion = 1;

bool read_numbers(const nlohmann::json& j, const char* key, std::map<std::string, double>& out,
                  std::string& error) {
  const auto it = j.find(key);
  if (it == j.end()) return true;
  if (!it->is_object()) {
    error = std::string("/") + key + ": expected an object of numbers";
    return false;
  }
  for (const auto& [name, value] : it->items()) {
    if (!value.is_number() || !std::isfinite(value.get<double>())) {
      error =
          std::string("/") + key + "/" + name + ": expected a finite number, got " + value.dump();
      return false;
    }
    out[name] = value.get<double>();
  }
  return true;
}

bool read_text(const nlohmann::json& j, const char* key, std::string& out, std::string& error) {
  const auto it = j.find(key);
  if (it == j.end() || !it->is_string()) {
    error = std::string("/") + key + ": expected a string";
    return false;
  }
  out = it->get<std::string>();
  return true;
}
}  // namespace

std::string write_calibration(const CalibrationFile& file) {
  nlohmann::ordered_json j = {{"format", kFormat},
                              {"version", kVersion},
                              {"unit", file.unit},
                              {"model", file.model},
                              {"parameters", file.parameters},
                              {"initial_std", file.initial_std},
                              {"point_offsets", file.point_offsets},
                              {"fit", file.fit}};
  return j.dump(2) + "\n";
}

std::optional<CalibrationFile> read_calibration(const std::string& text, std::string& error) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    error = std::string("not JSON: ") + e.what();
    return std::nullopt;
  }
  if (!j.is_object() || j.value("format", nlohmann::json()) != kFormat) {
    error = "/format: expected \"hvac-twin calibration\"";
    return std::nullopt;
  }
  const auto version = j.find("version");
  if (version == j.end() || !version->is_number_integer() || *version != kVersion) {
    error = "/version: expected 1";
    return std::nullopt;
  }
  for (const auto& [key, value] : j.items()) {
    (void)value;
    if (key != "format" && key != "version" && key != "unit" && key != "model" &&
        key != "parameters" && key != "initial_std" && key != "point_offsets" && key != "fit") {
      error = "/" + key +
              ": unknown key (expected format, version, unit, model, parameters, "
              "initial_std, point_offsets, fit)";
      return std::nullopt;
    }
  }
  CalibrationFile f;
  if (!read_text(j, "unit", f.unit, error) || !read_text(j, "model", f.model, error) ||
      !read_numbers(j, "parameters", f.parameters, error) ||
      !read_numbers(j, "initial_std", f.initial_std, error) ||
      !read_numbers(j, "point_offsets", f.point_offsets, error))
    return std::nullopt;
  return f;
}

}  // namespace hvac_twin::config
