#include "daemon/calibration/steady_windows.hpp"

#include <cmath>
#include <limits>

namespace hvac_twin::calibration {

WindowFinder::WindowFinder(std::vector<double> tolerance, std::size_t outputs, double period_s,
                           WindowOptions options)
    : tolerance_(std::move(tolerance)), outputs_(outputs), period_s_(period_s), options_(options) {}

void WindowFinder::close_segment() {
  if (!open_) return;
  open_ = false;
  if (cycles_ == 0 || last_t_ - window_start_ + period_s_ < options_.min_window_s) return;
  SteadyWindow w;
  w.start_s = window_start_;
  w.end_s = last_t_;
  w.cycles = cycles_;
  w.u.resize(u_sum_.size());
  for (std::size_t i = 0; i < u_sum_.size(); ++i)
    w.u[i] = u_sum_[i] / static_cast<double>(cycles_);
  w.y.assign(outputs_, std::numeric_limits<double>::quiet_NaN());
  for (std::size_t j = 0; j < outputs_; ++j)
    if (y_count_[j] >= options_.min_samples) w.y[j] = y_sum_[j] / static_cast<double>(y_count_[j]);
  windows_.push_back(std::move(w));
}

void WindowFinder::add(double t_s, const std::vector<double>& u, const std::vector<double>& y) {
  bool missing = false, moved = false;
  for (std::size_t i = 0; i < u.size(); ++i) {
    missing = missing || !std::isfinite(u[i]);
    moved = moved || (open_ && std::abs(u[i] - reference_[i]) > tolerance_[i]);
  }
  if (open_ && (missing || moved || t_s - last_t_ > 3.0 * period_s_)) close_segment();
  if (missing) return;
  if (!open_) {
    open_ = true;
    ++segments_;
    segment_start_ = t_s;
    reference_ = u;
    u_sum_.assign(u.size(), 0.0);
    y_sum_.assign(outputs_, 0.0);
    y_count_.assign(outputs_, 0);
    cycles_ = 0;
    window_start_ = -1.0;
  }
  last_t_ = t_s;
  if (t_s - segment_start_ < options_.settle_s) return;
  if (window_start_ < 0.0) window_start_ = t_s;
  ++cycles_;
  for (std::size_t i = 0; i < u.size(); ++i)
    u_sum_[i] += u[i];
  for (std::size_t j = 0; j < outputs_; ++j)
    if (std::isfinite(y[j])) {
      y_sum_[j] += y[j];
      ++y_count_[j];
    }
}

std::vector<SteadyWindow> WindowFinder::finish() {
  close_segment();
  return std::move(windows_);
}

}  // namespace hvac_twin::calibration
