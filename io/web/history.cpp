#include "io/web/history.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace hvac_twin::web {
namespace {

// Floor division for minute indices (timestamps before 1970 stay ordered).
std::int64_t minute_of(std::int64_t t_ms) noexcept {
  return t_ms >= 0 ? t_ms / Series::kMinuteMs
                   : -((-t_ms + Series::kMinuteMs - 1) / Series::kMinuteMs);
}

// Merges consecutive points into groups: mean value and sigma, envelope of the band.
class Grouper {
 public:
  explicit Grouper(std::vector<SeriesPoint>& out) : out_(out) {}
  void add(std::int64_t t_ms, double value, double sigma, double lo, double hi, double weight) {
    if (n_ == 0) {
      group_ = {t_ms, 0.0, 0.0, lo, hi};
    } else {
      group_.lo = std::min(group_.lo, lo);
      group_.hi = std::max(group_.hi, hi);
    }
    group_.value += value * weight;
    group_.sigma += sigma * weight;
    n_ += weight;
  }
  void flush() {
    if (n_ == 0) return;
    group_.value /= n_;
    group_.sigma /= n_;
    out_.push_back(group_);
    n_ = 0;
  }

 private:
  std::vector<SeriesPoint>& out_;
  SeriesPoint group_;
  double n_ = 0;
};

}  // namespace

Series::Series(std::size_t fine_capacity, std::size_t minute_capacity)
    : fine_capacity_(std::max<std::size_t>(fine_capacity, 1)),
      minute_capacity_(std::max<std::size_t>(minute_capacity, 1)) {
  fine_.reserve(fine_capacity_);
  minutes_.reserve(minute_capacity_);
}

std::size_t Series::bytes_for(std::size_t fine_capacity, std::size_t minute_capacity) noexcept {
  return sizeof(Series) + fine_capacity * sizeof(Sample) + minute_capacity * sizeof(Bucket);
}

const Series::Sample& Series::fine_at(std::size_t i) const noexcept {
  return fine_[(fine_head_ + i) % fine_.size()];
}

const Series::Bucket& Series::minute_at(std::size_t i) const noexcept {
  return minutes_[(minute_head_ + i) % minutes_.size()];
}

void Series::open_minute(std::int64_t minute) noexcept {
  // Empty buckets for the minutes without data in between; a gap longer than the ring clears it.
  const std::int64_t steps = minutes_.empty() ? 1 : minute - last_minute_;
  if (steps > static_cast<std::int64_t>(minute_capacity_)) {
    minutes_.clear();
    minute_head_ = 0;
  }
  const std::int64_t pushes =
      minutes_.empty() ? 1
                       : std::min<std::int64_t>(steps, static_cast<std::int64_t>(minute_capacity_));
  for (std::int64_t i = 0; i < pushes; ++i) {
    const Bucket empty{0.0f, 0.0f, 0.0f, 0.0f, 0};
    if (minutes_.size() < minute_capacity_) {
      minutes_.push_back(empty);
    } else {
      minutes_[minute_head_] = empty;
      minute_head_ = (minute_head_ + 1) % minute_capacity_;
    }
  }
  last_minute_ = minute;
}

bool Series::add(std::int64_t t_ms, double value, double sigma) noexcept {
  if (!std::isfinite(value) || !std::isfinite(sigma) || (!empty_ && t_ms <= last_t_ms_)) {
    ++dropped_;
    return false;
  }
  sigma = std::max(sigma, 0.0);
  const Sample sample{t_ms, static_cast<float>(value), static_cast<float>(sigma)};
  if (fine_.size() < fine_capacity_) {
    fine_.push_back(sample);
  } else {
    evicted_t_ms_ = fine_[fine_head_].t_ms;
    evicted_ = true;
    fine_[fine_head_] = sample;
    fine_head_ = (fine_head_ + 1) % fine_capacity_;
  }

  const std::int64_t minute = minute_of(t_ms);
  if (empty_ || minute > last_minute_) open_minute(minute);
  Bucket& b = minutes_[(minute_head_ + minutes_.size() - 1) % minutes_.size()];
  const float lo = static_cast<float>(value - 2.0 * sigma);
  const float hi = static_cast<float>(value + 2.0 * sigma);
  if (b.n == 0) {
    b = {sample.value, sample.sigma, lo, hi, 1};
  } else {  // running means (sum_* hold the means): no float sum grows with the sample count
    ++b.n;
    b.sum_value += (sample.value - b.sum_value) / static_cast<float>(b.n);
    b.sum_sigma += (sample.sigma - b.sum_sigma) / static_cast<float>(b.n);
    b.lo = std::min(b.lo, lo);
    b.hi = std::max(b.hi, hi);
  }
  last_t_ms_ = t_ms;
  empty_ = false;
  return true;
}

SeriesWindow Series::window(std::int64_t now_ms, std::int64_t window_ms,
                            std::size_t max_points) const {
  SeriesWindow out;
  if (empty_) return out;
  max_points = std::max<std::size_t>(max_points, 2);
  const std::int64_t from = now_ms - window_ms;
  // The fine ring holds every sample of the window unless it overwrote one inside it; then the
  // minute buckets older than its oldest sample come first, with half the points.
  const bool fine_complete = !evicted_ || evicted_t_ms_ < from;
  std::size_t fine_points = max_points;
  if (!fine_complete) {
    out.minute_resolution = true;
    const std::size_t minute_points = max_points / 2;
    fine_points = max_points - minute_points;
    const std::int64_t oldest_minute =
        last_minute_ - static_cast<std::int64_t>(minutes_.size()) + 1;
    const std::int64_t first_minute = std::max(oldest_minute, minute_of(from));
    // Up to the minute holding the fine ring's oldest sample (that minute's earlier samples
    // survive only in its bucket).
    const std::int64_t last_minute = std::min(last_minute_, minute_of(fine_at(0).t_ms));
    if (first_minute <= last_minute) {
      const auto span = static_cast<std::size_t>(last_minute - first_minute + 1);
      const std::size_t per_group = (span + minute_points - 1) / minute_points;
      out.points.reserve(std::min(span, minute_points) + std::min(fine_.size(), fine_points));
      Grouper group(out.points);
      for (std::int64_t m = first_minute; m <= last_minute; ++m) {
        const Bucket& b = minute_at(static_cast<std::size_t>(m - oldest_minute));
        if (b.n > 0)
          group.add(m * kMinuteMs, static_cast<double>(b.sum_value),
                    static_cast<double>(b.sum_sigma), static_cast<double>(b.lo),
                    static_cast<double>(b.hi), static_cast<double>(b.n));
        // Groups aligned to whole multiples of per_group minutes since the first.
        if (static_cast<std::size_t>(m - first_minute + 1) % per_group == 0) group.flush();
      }
      group.flush();
    }
  }
  // The first sample inside the window, by binary search over the ring (ordered by time).
  std::size_t lo = 0, hi = fine_.size();
  while (lo < hi) {
    const std::size_t mid = (lo + hi) / 2;
    if (fine_at(mid).t_ms < from)
      lo = mid + 1;
    else
      hi = mid;
  }
  const std::size_t count = fine_.size() - lo;
  const std::size_t per_group = (count + fine_points - 1) / fine_points;
  Grouper group(out.points);
  for (std::size_t i = lo, in_group = 0; i < fine_.size(); ++i) {
    const Sample& s = fine_at(i);
    const auto v = static_cast<double>(s.value), sd = static_cast<double>(s.sigma);
    group.add(s.t_ms, v, sd, v - 2.0 * sd, v + 2.0 * sd, 1.0);
    if (++in_group == per_group) {
      group.flush();
      in_group = 0;
    }
  }
  group.flush();
  return out;
}

}  // namespace hvac_twin::web
