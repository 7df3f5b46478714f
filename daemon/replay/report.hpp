// The replay's report: one self-contained HTML file (inline SVG, no script, nothing fetched)
// that shows a unit's recorded period at a glance: what each measured point read against the
// model's prediction and how surprised the filter was (its test ratio against the chi-square
// gate), the virtual sensors with their +-2 sigma band (and the smoothed estimate, if any), the
// charge against its references and the leak detector's CUSUMs against their threshold.
// Long replays are drawn in at most kMaxBins time bins (the bin's mean; svg_chart.hpp).
#pragma once

#include <map>
#include <string>

namespace hvac_twin::replay {

// Reads the replay's CSV (csv_sink.hpp) and, when not empty, the smoothed CSV (smoothing.hpp),
// and writes the report. `units`: the engineering unit of each point and model output, by name.
// Throws std::runtime_error naming a file that cannot be read or written.
void write_report(const std::string& replay_csv, const std::string& smoothed_csv,
                  const std::string& unit, const std::map<std::string, std::string>& units,
                  const std::string& html_path);

}  // namespace hvac_twin::replay
