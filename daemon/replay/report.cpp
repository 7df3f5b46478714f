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

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> out;
  std::string f;
  std::stringstream s(line);
  while (std::getline(s, f, ','))
    out.push_back(f);
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

Table read_table(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw std::runtime_error(path + ": cannot be read for the report");
  Table t;
  std::string line;
  if (!std::getline(in, line)) throw std::runtime_error(path + ": empty");
  t.columns = split(line);
  for (std::size_t i = 0; i < t.columns.size(); ++i)
    t.index.emplace(t.columns[i], i);
  while (std::getline(in, line))
    t.rows.push_back(split(line));
  return t;
}

std::string escape(const std::string& s) {
  std::string out;
  for (const char c : s) {
    if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '&')
      out += "&amp;";
    else
      out += c;
  }
  return out;
}

std::string fmt(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.4g", v);
  return b;
}

// Means per bin of the x (time) and of each series: at most kMaxBins points.
struct Binned {
  std::vector<double> x;
  std::vector<std::vector<double>> y;
};

Binned bin(const std::vector<double>& x, const std::vector<std::vector<double>>& ys) {
  const std::size_t n = x.size();
  const std::size_t per = std::max<std::size_t>(1, (n + kMaxBins - 1) / kMaxBins);
  Binned b;
  b.y.resize(ys.size());
  for (std::size_t start = 0; start < n; start += per) {
    const std::size_t end = std::min(n, start + per);
    double sx = 0.0;
    for (std::size_t i = start; i < end; ++i)
      sx += x[i];
    b.x.push_back(sx / static_cast<double>(end - start));
    for (std::size_t s = 0; s < ys.size(); ++s) {
      double sum = 0.0;
      int count = 0;
      for (std::size_t i = start; i < end; ++i)
        if (std::isfinite(ys[s][i])) {
          sum += ys[s][i];
          ++count;
        }
      b.y[s].push_back(count > 0 ? sum / count : kNaN);
    }
  }
  return b;
}

struct Line {
  std::string label, colour;
  std::vector<double> y;
  bool dashed = false;
};

struct Band {  // a filled +-2 sigma band around a value
  std::vector<double> lo, hi;
  std::string colour;
};

// One chart: lines and bands over time, with a caption.
// The time axis: since the first cycle, in s, min or h by the span.
struct Axis {
  std::vector<double> t;
  const char* unit = "h";
};
Axis time_axis(const std::vector<double>& stamps_ns) {
  Axis a;
  const double span_s = (stamps_ns.back() - stamps_ns.front()) * 1e-9;
  const double scale = span_s < 300.0 ? 1.0 : span_s < 7200.0 ? 60.0 : 3600.0;
  a.unit = span_s < 300.0 ? "s" : span_s < 7200.0 ? "min" : "h";
  for (const double s : stamps_ns)
    a.t.push_back((s - stamps_ns.front()) * 1e-9 / scale);
  return a;
}

void chart(std::ostream& o, const std::string& title, const std::string& unit,
           const std::string& caption, const Axis& axis, const std::vector<Line>& lines,
           const std::vector<Band>& bands = {}) {
  std::vector<std::vector<double>> all;
  for (const auto& b : bands) {
    all.push_back(b.lo);
    all.push_back(b.hi);
  }
  for (const auto& l : lines)
    all.push_back(l.y);
  const Binned d = bin(axis.t, all);
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (const auto& s : d.y)
    for (const double v : s)
      if (std::isfinite(v)) {
        lo = std::min(lo, v);
        hi = std::max(hi, v);
      }
  if (!std::isfinite(lo)) return;  // nothing to draw
  if (!(hi > lo)) hi = lo + 1.0;
  const double pad = 0.05 * (hi - lo);
  lo -= pad;
  hi += pad;
  const double W = 900, H = 220, L = 70, R = 160, T = 10, B = 30;
  const double x0 = d.x.front(), x1 = d.x.back() > x0 ? d.x.back() : x0 + 1e-9;
  auto X = [&](double v) { return L + (v - x0) / (x1 - x0) * (W - L - R); };
  auto Y = [&](double v) { return T + (hi - v) / (hi - lo) * (H - T - B); };
  o << "<figure><figcaption><b>" << escape(title) << "</b> [" << escape(unit)
    << "]: " << escape(caption) << "</figcaption>\n<svg role='img' viewBox='0 0 " << W << ' ' << H
    << "' width='100%'><title>" << escape(title) << "</title>\n<rect x='" << L << "' y='" << T
    << "' width='" << W - L - R << "' height='" << H - T - B << "' fill='none' stroke='#777'/>\n";
  for (int t = 0; t <= 4; ++t) {
    const double v = lo + (hi - lo) * t / 4.0;
    o << "<text x='" << L - 4 << "' y='" << Y(v) + 4 << "' text-anchor='end'>" << fmt(v)
      << "</text>\n";
    const double h = x0 + (x1 - x0) * t / 4.0;
    o << "<text x='" << X(h) << "' y='" << H - 8 << "' text-anchor='middle'>" << fmt(h) << ' '
      << axis.unit << "</text>\n";
  }
  for (std::size_t b = 0; b < bands.size(); ++b) {
    const auto& blo = d.y[2 * b];
    const auto& bhi = d.y[2 * b + 1];
    std::ostringstream pts;
    std::vector<std::size_t> ok;
    for (std::size_t i = 0; i < d.x.size(); ++i)
      if (std::isfinite(blo[i]) && std::isfinite(bhi[i])) ok.push_back(i);
    if (ok.size() < 2) continue;
    for (const std::size_t i : ok)
      pts << X(d.x[i]) << ',' << Y(bhi[i]) << ' ';
    for (auto it = ok.rbegin(); it != ok.rend(); ++it)
      pts << X(d.x[*it]) << ',' << Y(blo[*it]) << ' ';
    o << "<polygon points='" << pts.str() << "' fill='" << bands[b].colour
      << "' fill-opacity='0.2' stroke='none'/>\n";
  }
  for (std::size_t l = 0; l < lines.size(); ++l) {
    const auto& y = d.y[2 * bands.size() + l];
    o << "<polyline fill='none' stroke='" << lines[l].colour << "' stroke-width='1.5'"
      << (lines[l].dashed ? " stroke-dasharray='6 3'" : "") << " points='";
    for (std::size_t i = 0; i < d.x.size(); ++i)
      if (std::isfinite(y[i])) o << X(d.x[i]) << ',' << Y(y[i]) << ' ';
    o << "'/>\n<text x='" << W - R + 8 << "' y='" << T + 14 + 16.0 * static_cast<double>(l)
      << "' fill='" << lines[l].colour << "'>" << (lines[l].dashed ? "- - " : "— ")
      << escape(lines[l].label) << "</text>\n";
  }
  o << "</svg></figure>\n";
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
  o << "<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
       "<meta name='viewport' content='width=device-width, initial-scale=1'>"
       "<title>hvac-twin replay: "
    << escape(unit)
    << "</title><style>body{font-family:sans-serif;max-width:1000px;margin:auto;color:#111}"
       "figure{margin:1.5em 0}svg text{font-size:11px}table{border-collapse:collapse}"
       "td,th{border:1px solid #999;padding:2px 8px;text-align:right}</style></head><body>\n"
    << "<h1>Unit " << escape(unit) << ": " << t.rows.size() << " cycles over "
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
