// Steady operating windows in a unit's recorded cycles, for the batch calibration
// (daemon/estimation/batch_calibration.hpp).
//
// A segment is a run of cycles in which every model input stays within its tolerance of the
// segment's first value, with no gap longer than three periods and no input missing. Its first
// settle_s are the transient after the change; the rest, when at least min_window_s long, is a
// window: the inputs' and the measured outputs' means over it (an output with fewer than
// min_samples GOOD readings in it: NaN, not measured there).
#pragma once

#include <cstdint>
#include <vector>

namespace hvac_twin::calibration {

struct WindowOptions {
  double settle_s = 900.0;
  double min_window_s = 300.0;
  std::size_t min_samples = 10;
};

struct SteadyWindow {
  double start_s = 0.0, end_s = 0.0;  // since the first cycle
  std::size_t cycles = 0;
  std::vector<double> u, y;  // means in model units; y NaN where not measured
};

class WindowFinder {
 public:
  // tolerance: per model input, the largest change within a segment [input unit].
  WindowFinder(std::vector<double> tolerance, std::size_t outputs, double period_s,
               WindowOptions options);

  // One cycle at t_s: its inputs (NaN: missing; ends the segment) and measured outputs (NaN:
  // no GOOD reading).
  void add(double t_s, const std::vector<double>& u, const std::vector<double>& y);
  // Closes the last segment; returns the windows in time order.
  std::vector<SteadyWindow> finish();

  [[nodiscard]] std::size_t segments() const { return segments_; }

 private:
  void close_segment();

  std::vector<double> tolerance_;
  std::size_t outputs_;
  double period_s_;
  WindowOptions options_;
  std::vector<SteadyWindow> windows_;
  // The open segment.
  bool open_ = false;
  double segment_start_ = 0.0, last_t_ = 0.0;
  std::vector<double> reference_, u_sum_, y_sum_;
  std::vector<std::size_t> y_count_;
  double window_start_ = -1.0;
  std::size_t cycles_ = 0, segments_ = 0;
};

}  // namespace hvac_twin::calibration
