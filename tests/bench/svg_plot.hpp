// A minimal SVG line plot for benchmark reports: stacked panels sharing the x axis, one
// polyline per series, axis labels and a legend. No dependencies.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

namespace hvac_twin::bench {

struct Series {
  std::string label;
  std::string colour;
  std::vector<double> y;
};

struct Panel {
  std::string title;
  std::string unit;
  std::vector<Series> series;
};

inline void write_svg(const std::string& path, const std::string& title,
                      const std::vector<double>& x, const std::string& x_label,
                      const std::vector<Panel>& panels) {
  const double W = 960, H_panel = 300, left = 80, right = 170, top = 40, gap = 50;
  const double H = top + static_cast<double>(panels.size()) * (H_panel + gap);
  std::ofstream f(path);
  f << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='" << H
    << "' font-family='sans-serif' font-size='12'>\n<rect width='100%' height='100%' "
       "fill='white'/>\n<text x='"
    << W / 2 << "' y='22' text-anchor='middle' font-size='15'>" << title << "</text>\n";
  // A run too short to record a sample (e.g. --hours below the first sample) draws empty axes.
  const double x0 = x.empty() ? 0.0 : x.front();
  const double x1 = !x.empty() && x.back() > x0 ? x.back() : x0 + 1;
  for (std::size_t p = 0; p < panels.size(); ++p) {
    const Panel& panel = panels[p];
    double lo = 1e300, hi = -1e300;
    for (const auto& s : panel.series)
      for (double v : s.y)
        if (std::isfinite(v)) {
          lo = std::min(lo, v);
          hi = std::max(hi, v);
        }
    if (!(hi > lo)) hi = lo + 1;
    const double pad = 0.05 * (hi - lo);
    lo -= pad;
    hi += pad;
    const double oy = top + static_cast<double>(p) * (H_panel + gap), pw = W - left - right;
    const auto X = [&](double v) { return left + (v - x0) / (x1 - x0) * pw; };
    const auto Y = [&](double v) { return oy + H_panel - (v - lo) / (hi - lo) * H_panel; };
    f << "<rect x='" << left << "' y='" << oy << "' width='" << pw << "' height='" << H_panel
      << "' fill='none' stroke='#888'/>\n";
    f << "<text x='" << left << "' y='" << oy - 6 << "'>" << panel.title << " [" << panel.unit
      << "]</text>\n";
    for (int t = 0; t <= 4; ++t) {
      const double v = lo + (hi - lo) * t / 4.0;
      char buf[64];
      std::snprintf(buf, sizeof buf, "%.4g", v);
      f << "<text x='" << left - 6 << "' y='" << Y(v) + 4 << "' text-anchor='end'>" << buf
        << "</text>\n";
      const double xv = x0 + (x1 - x0) * t / 4.0;
      std::snprintf(buf, sizeof buf, "%.3g", xv);
      f << "<text x='" << X(xv) << "' y='" << oy + H_panel + 16 << "' text-anchor='middle'>" << buf
        << "</text>\n";
    }
    for (std::size_t s = 0; s < panel.series.size(); ++s) {
      const Series& series = panel.series[s];
      f << "<polyline fill='none' stroke='" << series.colour << "' stroke-width='1.2' points='";
      for (std::size_t i = 0; i < x.size() && i < series.y.size(); ++i)
        if (std::isfinite(series.y[i])) f << X(x[i]) << ',' << Y(series.y[i]) << ' ';
      f << "'/>\n<text x='" << W - right + 10 << "' y='" << oy + 16 + 16 * static_cast<double>(s)
        << "' fill='" << series.colour << "'>" << series.label << "</text>\n";
    }
  }
  f << "<text x='" << left + (W - left - right) / 2 << "' y='" << H - 10
    << "' text-anchor='middle'>" << x_label << "</text>\n</svg>\n";
}

}  // namespace hvac_twin::bench
