#include "daemon/replay/svg_chart.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

namespace hvac_twin::replay {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

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

}  // namespace

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
           const std::vector<Band>& bands) {
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
    if (lines[l].markers)
      for (std::size_t i = 0; i < d.x.size(); ++i)
        if (std::isfinite(y[i]))
          o << "<circle cx='" << X(d.x[i]) << "' cy='" << Y(y[i]) << "' r='3' fill='"
            << lines[l].colour << "'/>\n";
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

void page_start(std::ostream& o, const std::string& title) {
  o << "<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'>"
       "<meta name='viewport' content='width=device-width, initial-scale=1'><title>"
    << escape(title)
    << "</title><style>body{font-family:sans-serif;max-width:1000px;margin:auto;color:#111}"
       "figure{margin:1.5em 0}svg text{font-size:11px}table{border-collapse:collapse}"
       "td,th{border:1px solid #999;padding:2px 8px;text-align:right}</style></head><body>\n";
}

}  // namespace hvac_twin::replay
