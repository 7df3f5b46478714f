// The cycles of a replay's (or a calibration's) input files, in order: the daemon's recordings
// of a unit (files, or directories holding them), or one points CSV from a BMS or historian
// (csv_points.hpp). Shared by hvac-twin-replay and hvac-twin-calibrate.
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "daemon/recording/recording_reader.hpp"
#include "daemon/replay/csv_points.hpp"

namespace hvac_twin::replay {

[[nodiscard]] bool is_csv(const std::string& path);

// The recording's points are the configured unit's: same names, order and units. Throws
// recording::RecordingError naming the file and the first point that differs.
void check_points(const recording::RecordingReader& r, const config::UnitConfig& unit);

// The files to read, in order: files as given, directories expanded to the unit's recordings
// (oldest first). Throws recording::RecordingError for a directory without any.
std::vector<std::string> expand_inputs(const std::vector<std::string>& inputs,
                                       const std::string& unit);

// The unit of the inputs: `unit` when given, else the first recording's, else (a CSV or a
// directory) the configuration's only unit. Throws recording::RecordingError when ambiguous.
std::string pick_unit(const std::string& unit, const std::vector<std::string>& inputs,
                      const config::Config& config);

class CycleReader {
 public:
  using Warn = std::function<void(const std::string&)>;
  // files: expand_inputs()'s; a CSV must be the only file. input_hold_s: csv_points.hpp.
  // Throws recording::RecordingError for a bad first file.
  CycleReader(std::vector<std::string> files, const config::UnitConfig& unit, double input_hold_s,
              Warn warn);
  ~CycleReader();
  CycleReader(const CycleReader&) = delete;
  CycleReader& operator=(const CycleReader&) = delete;

  // The next cycle; false after the last. `new_run` is set on the first cycle and on the first
  // cycle of a recording made by another run of the daemon (whose estimator started again).
  // Throws recording::RecordingError naming the file and the record or line of bad input.
  bool next(recording::RecordedCycle& out, bool& new_run);

  [[nodiscard]] std::size_t files() const { return files_.size(); }
  [[nodiscard]] std::size_t torn_tails() const { return torn_; }

 private:
  bool open_next_recording();  // false when no file is left

  std::vector<std::string> files_;
  const config::UnitConfig& unit_;
  Warn warn_;
  std::unique_ptr<CsvPoints> csv_;
  std::unique_ptr<recording::RecordingReader> recording_;
  std::size_t next_file_ = 0, torn_ = 0;
  std::int64_t run_ = 0;
  bool started_ = false, run_changed_ = false;
};

}  // namespace hvac_twin::replay
