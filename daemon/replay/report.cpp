#include "daemon/replay/report.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "daemon/replay/csv_points.hpp"
#include "daemon/replay/svg_chart.hpp"

namespace hvac_twin::replay {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Table {
  std::vector<std::string> columns;
  std::map<std::string, std::size_t> index;
  std::vector<std::vector<std::string>> rows;

  bool has(const std::string& c) const { return index.count(c) != 0; }
  std::vector<double> numbers(const std::string& c) const {
    std::vector<double> out;
    const auto it = index.find(c);
    for (const auto& r : rows) {
      const std::string* f = it == index.end() || it->second >= r.size() ? nullptr : &r[it->second];
      out.push_back(f == nullptr || f->empty() ? kNaN : std::strtod(f->c_str(), nullptr));
    }
    return out;
  }
  std::vector<std::string> text(const std::string& c) const {
    std::vector<std::string> out;
    const auto it = index.find(c);
    for (const auto& r : rows)
      out.push_back(it == index.end() || it->second >= r.size() ? "" : r[it->second]);
    return out;
  }
};

Table read_table(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot be read for the report");
  Table t;
  std::string line;
  if (!std::getline(in, line)) throw std::runtime_error(path + ": empty");
  t.columns = split_csv_line(line);
  for (std::size_t i = 0; i < t.columns.size(); ++i)
    t.index.emplace(t.columns[i], i);
  while (std::getline(in, line))
    t.rows.push_back(split_csv_line(line));
  return t;
}

std::vector<double> add(const std::vector<double>& a, const std::vector<double>& b, double k) {
  std::vector<double> out(a.size());
  for (std::size_t i = 0; i < a.size(); ++i)
    out[i] = a[i] + k * b[i];
  return out;
}

}  // namespace

void write_report(const std::string& replay_csv, const std::string& smoothed_csv,
                  const std::string& unit, const std::map<std::string, std::string>& units,
                  const std::string& html_path) {
  const auto unit_of = [&](const std::string& name) {
    const auto it = units.find(name);
    return it == units.end() ? std::string("?") : it->second;
  };
  const Table t = read_table(replay_csv);
  if (t.rows.empty()) throw std::runtime_error(replay_csv + ": no cycles to report");
  Table smooth;
  if (!smoothed_csv.empty()) smooth = read_table(smoothed_csv);
  const auto stamps = t.numbers("timestamp_ns");
  const Axis hours = time_axis(stamps);
  const auto quality = t.text("quality");
  std::map<std::string, std::size_t> quality_count;
  for (const auto& q : quality)
    ++quality_count[q];

  std::ofstream o(html_path);
  if (!o) throw std::runtime_error(html_path + ": cannot be written");
  page_start(o, "hvac-twin replay: " + unit);
  o << "<h1>Unit " << escape(unit) << ": " << t.rows.size() << " cycles over "
    << fmt(hours.t.back()) << ' ' << hours.unit << "</h1>\n<p>Estimate quality: ";
  for (const auto& [q, n] : quality_count)
    o << escape(q.empty() ? "none" : q) << ' ' << n << " cycles ("
      << fmt(100.0 * static_cast<double>(n) / static_cast<double>(t.rows.size())) << " %); ";
  o << "</p>\n";

  // Measured points: what they read against the model, and how surprised the filter was.
  std::vector<std::string> points;
  for (const auto& c : t.columns)
    if (c.size() > 10 && c.compare(c.size() - 10, 10, "_predicted") == 0)
      points.push_back(c.substr(0, c.size() - 10));
  o << "<h2>Measured points</h2>\n<p>Each point's reading (measured = prediction + innovation) "
       "against the model's prediction before the update, and the filter's test ratio "
       "(innovation² / its variance): about 1 on average when the filter's uncertainty is "
       "honest; above the gate it is not fused.</p>\n<table><tr><th>point</th><th>mean test "
       "ratio</th><th>fused</th></tr>\n";
  for (const auto& p : points) {
    const auto r = t.numbers(p + "_test_ratio");
    const auto f = t.numbers(p + "_fused");
    double sum = 0.0, fused = 0.0;
    int n = 0;
    for (std::size_t i = 0; i < r.size(); ++i) {
      if (std::isfinite(r[i])) {
        sum += r[i];
        ++n;
      }
      if (f[i] == 1.0) fused += 1.0;
    }
    o << "<tr><td style='text-align:left'>" << escape(p) << "</td><td>"
      << (n > 0 ? fmt(sum / n) : "-") << "</td><td>"
      << fmt(100.0 * fused / static_cast<double>(r.size())) << " %</td></tr>\n";
  }
  o << "</table>\n";
  for (const auto& p : points) {
    const auto pred = t.numbers(p + "_predicted");
    chart(o, p, unit_of(p), "measured (blue) against the model's prediction (orange)", hours,
          {{"measured", "#1f5fbf", add(pred, t.numbers(p + "_innovation"), 1.0)},
           {"predicted", "#d9730d", pred}});
  }
  {
    std::vector<Line> lines;
    const char* colours[] = {"#1f5fbf", "#d9730d", "#2a9d3a", "#b02a2a",
                             "#7b3fbf", "#8a6d00", "#0f8a8a", "#555555"};
    for (std::size_t i = 0; i < points.size(); ++i)
      lines.push_back({points[i], colours[i % 8], t.numbers(points[i] + "_test_ratio")});
    chart(o, "Test ratio per point", "1",
          "innovation² / its variance per measured point (bin means)", hours, lines);
  }

  // Virtual sensors.
  o << "<h2>Virtual sensors</h2>\n<p>Estimated, not measured: the value with its ± 2σ band"
    << (smooth.rows.empty() ? "" : "; dashed, the smoothed after-the-fact estimate") << ".</p>\n";
  const char* shown[] = {"cooling_capacity",
                         "condenser_heat_flow",
                         "evaporator_heat_flow",
                         "compressor_power",
                         "cop",
                         "condenser_outlet_pressure",
                         "valve_inlet_enthalpy",
                         "superheat",
                         "subcooling",
                         "charge",
                         "leak_rate",
                         "outdoor_coil_fouling",
                         "internal_gains",
                         "mass_temperature"};
  for (const char* name : shown) {
    if (!t.has(name)) continue;
    const auto v = t.numbers(name), s = t.numbers(std::string(name) + "_sigma");
    std::vector<Line> lines{{"estimate", "#1f5fbf", v}};
    if (smooth.has(name)) lines.push_back({"smoothed", "#d9730d", smooth.numbers(name), true});
    chart(o, name, unit_of(name), "the filter's estimate with its ± 2σ band", hours, lines,
          {{add(v, s, -2.0), add(v, s, 2.0), "#1f5fbf"}});
  }

  // Leak detection.
  if (t.has("leak_diag_charge")) {
    o << "<h2>Charge and leak detection</h2>\n<p>The detector compares the charge with the "
         "references it learnt per operating band, and accumulates evidence of a leak in two "
         "CUSUMs; one above the threshold raises SUSPECT, then LEAK. Final state: "
      << escape(t.text("leak_diag_state").back()) << ".</p>\n";
    const auto c = t.numbers("leak_diag_charge"), cs = t.numbers("leak_diag_charge_sigma");
    auto reference = t.numbers("leak_diag_charge_reference");
    for (double& r : reference)
      if (r == 0.0) r = kNaN;  // 0: none learnt yet
    chart(o, "Charge", "kg", "the charge the detector judges, ± 2σ, and its learnt reference",
          hours, {{"charge", "#1f5fbf", c}, {"reference", "#2a9d3a", reference, true}},
          {{add(c, cs, -2.0), add(c, cs, 2.0), "#1f5fbf"}});
    chart(o, "Leak CUSUMs", "σ", "the rate and the charge-deficit CUSUMs against the threshold",
          hours,
          {{"rate CUSUM", "#1f5fbf", t.numbers("leak_diag_rate_cusum")},
           {"charge CUSUM", "#d9730d", t.numbers("leak_diag_charge_cusum")},
           {"threshold", "#b02a2a", t.numbers("leak_diag_threshold"), true}});
  }
  o << "<p>Written by hvac-twin-replay from " << escape(replay_csv) << ".</p></body></html>\n";
  if (!o) throw std::runtime_error(html_path + ": write failed");
}

}  // namespace hvac_twin::replay
