// Point values from a CSV a user exports from a BMS or historian, turned into the cycles the
// daemon would have run on them.
//
// The format (README "Replay"): an optional run of comment lines starting with '#', a header row
// "time,<point>,<point>,..." naming points of the unit (any order, any subset), then one row per
// time in non-decreasing order. `time` is seconds since the Unix epoch, or ISO 8601 UTC
// "YYYY-MM-DDTHH:MM:SS[.fff][Z|+HH:MM|-HH:MM]" (a space for the T works too). A value is in the
// point's configured engineering unit (after its scale and offset); an empty field: no reading
// at that time.
//
// Cycles run every period_s from the first row's time to the last row's. In each, a point has
// its latest reading at or before the cycle:
//  - a measured point is GOOD in the first cycle at or after its reading, then STALE until the
//    next reading: each reading is fused once, as the daemon fuses each poll once;
//  - an input is GOOD while its reading is younger than the point's stale_after_s (or the
//    replay's --input-hold-s), then STALE (the pipeline holds its last value and says so);
//  - a reading outside the point's configured range is OUT_OF_RANGE, as the poller makes it;
//  - before its first reading, NOT_YET_READ.
#pragma once

#include <cstdint>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "daemon/recording/recording_format.hpp"

namespace hvac_twin::replay {

// The comma-separated fields of a line, each without surrounding white space; a trailing comma
// is a last, empty field. (No quoting: point names and numbers have no commas.)
std::vector<std::string> split_csv_line(const std::string& line);

// Parses a `time` field; nullopt if it is neither form. [ns since the Unix epoch, UTC]
std::optional<std::int64_t> parse_time(const std::string& field);

class CsvPoints {
 public:
  // Reads the header; throws recording::RecordingError naming the file, the line and what was
  // wrong (an unknown point, a repeated column, no time column). input_hold_s <= 0: each input
  // point's stale_after_s.
  CsvPoints(std::string path, const config::UnitConfig& unit, double input_hold_s);

  // The next cycle; false after the last row's time. Throws recording::RecordingError naming
  // the file, line and column of a bad field or a time going backwards.
  bool next(recording::RecordedCycle& out);

  [[nodiscard]] const std::vector<std::string>& missing_points() const { return missing_; }

 private:
  bool next_line(std::string& line);  // the next line that is not blank or a comment
  bool read_row();                    // into row_time_ / row_; false at the end of the file
  [[noreturn]] void fail(const std::string& what) const;

  struct Point {
    std::size_t index = 0;  // in the unit's points
    bool measured = false;
    double hold_ns = 0.0;  // an input's reading stays GOOD this long
    double min = 0.0, max = 0.0;
    bool have = false;   // a reading so far
    bool fused = false;  // measured: its latest reading was handed out GOOD
    double value = 0.0;
    std::int64_t time_ns = 0;
  };

  std::string path_;
  std::ifstream in_;
  std::uint64_t line_ = 0;
  std::vector<long> column_point_;  // per column after `time`: index into points_
  std::vector<Point> points_;       // one per unit point, in the unit's order
  std::vector<std::string> missing_;
  std::int64_t period_ns_ = 0;
  // The row read ahead.
  bool have_row_ = false;
  std::int64_t row_time_ = 0;
  std::vector<std::optional<double>> row_;
  std::uint64_t cycle_ = 0;
  std::int64_t first_ns_ = 0;
  std::int64_t last_row_ns_ = 0;
  bool started_ = false;
};

}  // namespace hvac_twin::replay
