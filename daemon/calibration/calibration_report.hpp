// hvac-twin-calibrate's report: one self-contained HTML file (inline SVG, nothing fetched) of a
// fit: the parameters against their prior, each measured point's residual per window at the
// nominal and at the fitted parameters against its sensor's +-2 sigma, and the windows used.
#pragma once

#include <map>
#include <nlohmann/json.hpp>
#include <string>

namespace hvac_twin::calibration {

// fit: the calibration file's "fit" object (calibrate_main.cpp writes it); units and sigma: each
// measured output's unit and sensor sigma, by name. Throws std::runtime_error naming a file that
// cannot be written.
void write_calibration_report(const nlohmann::ordered_json& fit, const std::string& unit,
                              const std::map<std::string, std::string>& units,
                              const std::map<std::string, double>& sigma,
                              const std::string& html_path);

}  // namespace hvac_twin::calibration
