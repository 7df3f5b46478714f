// A unit's calibration file: what hvac-twin-calibrate fitted, for the unit's configuration to
// include ("calibration": "<file>", config/README.md).
//
//   {"format": "hvac-twin calibration", "version": 1, "unit": "hp1", "model": "heat_pump_r32",
//    "parameters": {"fouling": 0.84, ...},   -> the unit's model.parameters
//    "initial_std": {"fouling": 0.024, ...}, -> the unit's estimator.initial_std
//    "point_offsets": {"zone_temp": 0.3},     -> added to that point's offset [point's unit]
//    "fit": {...}}                            what the fit saw (windows, residuals): not read
//
// load_config_file() applies it: the values go where the arrows say and are validated as if they
// were written there; a parameter or sigma the configuration sets itself as well is an error (one
// source per value; a point offset is a correction, added to the configured one), and every
// error names the calibration file and the key in it.
#pragma once

#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

namespace hvac_twin::config {

struct CalibrationFile {
  std::string unit, model;
  std::map<std::string, double> parameters, initial_std, point_offsets;
  nlohmann::ordered_json fit = nlohmann::ordered_json::object();
};

std::string write_calibration(const CalibrationFile& file);

// Parses a calibration file's text; on failure nullopt and `error` says what was wrong, with the
// JSON pointer of the value inside the file.
std::optional<CalibrationFile> read_calibration(const std::string& text, std::string& error);

}  // namespace hvac_twin::config
