#include "daemon/calibration/calibration_report.hpp"

#include <cmath>
#include <fstream>
#include <limits>
#include <stdexcept>
#include <vector>

#include "daemon/replay/svg_chart.hpp"

namespace hvac_twin::calibration {

using replay::escape;
using replay::fmt;

void write_calibration_report(const nlohmann::ordered_json& fit, const std::string& unit,
                              const std::map<std::string, std::string>& units,
                              const std::map<std::string, double>& sigma,
                              const std::string& html_path) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  std::ofstream o(html_path);
  if (!o) throw std::runtime_error(html_path + ": cannot be written");
  const auto& windows = fit.at("windows");
  replay::page_start(o, "hvac-twin calibration: " + unit);
  o << "<h1>Unit " << escape(unit) << ": calibration on " << windows.size()
    << " steady windows, charge " << fmt(fit.at("charge_kg").get<double>()) << " kg</h1>\n"
    << "<p>χ² of the " << fit.at("residuals").get<std::size_t>() << " residuals (each in units of "
    << "its sensor's σ): " << fmt(fit.at("chi_square_nominal").get<double>())
    << " at the nominal parameters, " << fmt(fit.at("chi_square").get<double>())
    << " fitted. The parameters' σ is scaled by " << fmt(fit.at("sigma_scale").get<double>())
    << " (the square root of χ² per residual when that is above 1).</p>\n";

  o << "<h2>Parameters</h2>\n<table><tr><th>parameter</th><th>prior</th><th>± σ</th>"
       "<th>fitted</th><th>± σ</th><th>σ / prior σ</th></tr>\n";
  for (const auto& [name, p] : fit.at("parameters").items()) {
    const double ratio = p.at("sigma").get<double>() / p.at("prior_sigma").get<double>();
    o << "<tr><th>" << escape(name) << "</th><td>" << fmt(p.at("prior").get<double>())
      << "</td><td>" << fmt(p.at("prior_sigma").get<double>()) << "</td><td>"
      << fmt(p.at("value").get<double>()) << "</td><td>" << fmt(p.at("sigma").get<double>())
      << "</td><td>" << fmt(ratio) << (ratio > 0.7 ? " (the windows hardly tell it)" : "")
      << "</td></tr>\n";
  }
  o << "</table>\n<p>A σ near its prior's means the windows did not determine the parameter; it "
       "stays near its nominal value.</p>\n";

  // Residuals per measured output, window by window.
  replay::Axis axis;
  axis.unit = "h";
  for (const auto& w : windows)
    axis.t.push_back(0.5 * (w.at("start_s").get<double>() + w.at("end_s").get<double>()) / 3600.0);
  o << "<h2>Residuals</h2>\n<p>Measured minus model at each window's steady state, at the "
       "nominal and at the fitted parameters, against the sensor's ± 2σ (shaded).</p>\n";
  for (const auto& [name, s] : sigma) {
    std::vector<double> nominal, fitted, lo, hi;
    for (const auto& w : windows) {
      const auto& r = w.at("residuals");
      const bool have = r.contains(name);
      const double m = have ? r[name].at("measured").get<double>() : kNaN;
      nominal.push_back(have ? m - r[name].at("nominal").get<double>() : kNaN);
      fitted.push_back(have ? m - r[name].at("fitted").get<double>() : kNaN);
      lo.push_back(-2.0 * s);
      hi.push_back(2.0 * s);
    }
    const auto u = units.find(name);
    replay::chart(
        o, name, u == units.end() ? "?" : u->second, "measured − model, window by window", axis,
        {{"nominal", "#d9730d", nominal, true, true}, {"fitted", "#1f5fbf", fitted, false, true}},
        {{lo, hi, "#777777"}});
  }

  o << "<h2>Windows</h2>\n<table><tr><th>from [h]</th><th>to [h]</th><th>used</th></tr>\n";
  for (const auto& w : windows)
    o << "<tr><td>" << fmt(w.at("start_s").get<double>() / 3600.0) << "</td><td>"
      << fmt(w.at("end_s").get<double>() / 3600.0) << "</td><td>"
      << (w.at("used").get<bool>() ? "yes" : "no: " + escape(w.value("why", std::string())))
      << "</td></tr>\n";
  o << "</table>\n<p>Written by hvac-twin-calibrate.</p></body></html>\n";
  if (!o) throw std::runtime_error(html_path + ": write failed");
}

}  // namespace hvac_twin::calibration
