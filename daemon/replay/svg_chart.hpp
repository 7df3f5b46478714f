// Inline-SVG line charts for the tools' self-contained HTML reports (hvac-twin-replay's,
// hvac-twin-calibrate's): no script, nothing fetched. Long series are drawn in at most kMaxBins
// bins (the bin's mean).
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace hvac_twin::replay {

inline constexpr std::size_t kMaxBins = 1200;

std::string escape(const std::string& s);  // for HTML text
std::string fmt(double v);                 // 4 significant digits

struct Line {
  std::string label, colour;
  std::vector<double> y;
  bool dashed = false;
  bool markers = false;  // a dot at each point (few points: a calibration's windows)
};

struct Band {  // a filled band, e.g. +-2 sigma around a value
  std::vector<double> lo, hi;
  std::string colour;
};

// The x axis: its values and their unit.
struct Axis {
  std::vector<double> t;
  const char* unit = "h";
};
// Time since the first stamp, in s, min or h by the span.
Axis time_axis(const std::vector<double>& stamps_ns);

// One chart: lines and bands over the axis, with a title, the values' unit and a caption.
void chart(std::ostream& o, const std::string& title, const std::string& unit,
           const std::string& caption, const Axis& axis, const std::vector<Line>& lines,
           const std::vector<Band>& bands = {});

// The page's head up to and including <body>, titled `title`.
void page_start(std::ostream& o, const std::string& title);

}  // namespace hvac_twin::replay
