// One run of hvac-twin-calibrate for one unit: its model with the fitted parameters carried as
// states, its points mapped to the model's inputs and outputs, the steady windows of the input
// files, the fit (est::calibrate), and what it writes: the calibration file and the report.
#pragma once

#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "config/calibration_file.hpp"
#include "config/config.hpp"
#include "config/units.hpp"
#include "daemon/calibration/steady_windows.hpp"
#include "daemon/estimation/batch_calibration.hpp"
#include "daemon/replay/cycle_reader.hpp"
#include "plant_models/core/model.hpp"

namespace hvac_twin::calibration {

// A bad --fit, --offsets or --charge (the tool's exit status 2).
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct JobOptions {
  std::vector<std::string> fit;      // parameter names; empty: the unit's estimated factors
  std::vector<std::string> offsets;  // "POINT=SIGMA" (sigma in the point's unit)
  double charge = 0.0;               // kg
  WindowOptions windows;
};

class CalibrationJob {
 public:
  // Throws UsageError naming what was wrong.
  CalibrationJob(const config::UnitConfig& unit, JobOptions options);

  struct ReadSummary {
    std::size_t cycles = 0, segments = 0, windows = 0;  // windows: all steady ones found
    std::vector<std::string> left_out;  // windows not fitted, and why ("12-14 h: ...")
  };
  // The steady windows of the reader's cycles, added to the fit (not those where a fitted
  // parameter is unexcited). Throws recording::RecordingError for bad input data.
  ReadSummary read(replay::CycleReader& reader);

  [[nodiscard]] std::size_t windows() const { return problem_.windows.size(); }
  [[nodiscard]] est::CalibrationResult fit() const;

  // The fitted values and offsets, one line each, and the fit's summary.
  void print(std::FILE* to, const est::CalibrationResult& r, double seconds) const;
  // The calibration file, its "fit" object recording the fit for the report; inputs: the files.
  [[nodiscard]] config::CalibrationFile file(const est::CalibrationResult& r,
                                             const std::vector<std::string>& inputs) const;
  void report(const config::CalibrationFile& file, const std::string& html_path) const;

 private:
  // A point feeding a model input or output, in the model's unit.
  struct Feed {
    std::size_t point, index;
    config::Conversion to_model;
  };
  // A fitted offset in its point's unit: the reading's bias.
  struct PointOffset {
    std::string point, unit;
    double prior_std, value, std;
  };
  void bind_points();
  void bind_offsets();
  [[nodiscard]] std::vector<PointOffset> point_offsets(const est::CalibrationResult& r) const;

  const config::UnitConfig& unit_;
  JobOptions o_;
  std::vector<std::string> fit_;
  std::unique_ptr<plant::ContinuousModel> configured_, model_;
  std::size_t charge_state_ = 0;
  est::CalibrationProblem problem_;
  std::vector<Feed> inputs_, outputs_;
  std::vector<double> tolerance_;
  std::vector<std::size_t> offset_feed_;  // into outputs_, in the fit's order
};

}  // namespace hvac_twin::calibration
