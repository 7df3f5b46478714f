// The bounded history of one time series (a virtual sensor, a point's innovation, a CUSUM...):
// value and 1-sigma per sample, kept twice:
//  - fine: the last `fine_capacity` samples at full resolution (a ring);
//  - coarse: one bucket per wall-clock minute for the last `minute_capacity` minutes (a ring
//    indexed by the minute, so a gap in the data is an empty bucket), each the mean value, the
//    mean sigma and the envelope of the ±2σ band (lo = min(v − 2σ), hi = max(v + 2σ)), so the
//    band survives the downsampling.
// Memory is fixed by the two capacities (bytes_for()); nothing grows with time.
//
// Time is data: samples carry their own timestamps (the publisher's CLOCK_REALTIME, in ms); a
// sample not newer than the last one is dropped (duplicates, a clock stepping back).
//
// Threads: none of its own; the owner (Store) serialises access. Allocation: the constructor
// reserves both rings; add() never allocates; window() allocates its result.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace hvac_twin::web {

// One point of a series as the page draws it: the band [lo, hi] around the value.
struct SeriesPoint {
  std::int64_t t_ms = 0;  // sample time (fine) or the start of the group (aggregated) [ms]
  double value = 0.0;     // the sample, or the mean of the group
  double sigma = 0.0;     // its 1-sigma, or the mean 1-sigma of the group
  double lo = 0.0;        // min(v - 2 sigma) over the group
  double hi = 0.0;        // max(v + 2 sigma) over the group
};

// What window() returns: points oldest first and the resolution they come from.
struct SeriesWindow {
  bool minute_resolution = false;  // true: minute buckets first, then the fine ring's samples
  std::vector<SeriesPoint> points;
};

class Series {
 public:
  static constexpr std::int64_t kMinuteMs = 60'000;

  Series(std::size_t fine_capacity, std::size_t minute_capacity);

  // Adds a sample at t_ms (value and 1-sigma, sigma >= 0; NaN or infinite values are dropped).
  // Returns false if it was dropped (not newer than the last, or not finite).
  bool add(std::int64_t t_ms, double value, double sigma) noexcept;

  // The samples with t >= now_ms - window_ms, at most `max_points` of them (consecutive samples
  // merged into groups when there are more: mean value and sigma, envelope of the band). From the
  // fine ring when it holds every sample of the window (none it overwrote is inside it);
  // otherwise the minute buckets up to the fine ring's oldest sample (at most max_points / 2
  // points), then the fine ring (the rest): the recent end always at full resolution.
  SeriesWindow window(std::int64_t now_ms, std::int64_t window_ms, std::size_t max_points) const;

  std::size_t fine_size() const noexcept { return fine_.size(); }
  std::size_t minute_size() const noexcept { return minutes_.size(); }
  std::size_t fine_capacity() const noexcept { return fine_capacity_; }
  std::size_t minute_capacity() const noexcept { return minute_capacity_; }
  std::int64_t last_t_ms() const noexcept { return last_t_ms_; }
  std::uint64_t dropped() const noexcept { return dropped_; }

  // Heap bytes of a series with these capacities (both rings full).
  static std::size_t bytes_for(std::size_t fine_capacity, std::size_t minute_capacity) noexcept;

 private:
  struct Sample {  // 16 bytes; float keeps 7 significant digits, more than the page shows
    std::int64_t t_ms;
    float value;
    float sigma;
  };
  struct Bucket {  // 20 bytes; n == 0: no sample in that minute
    float sum_value;
    float sum_sigma;
    float lo;
    float hi;
    std::uint32_t n;
  };

  const Sample& fine_at(std::size_t i) const noexcept;    // i = 0: oldest
  const Bucket& minute_at(std::size_t i) const noexcept;  // i = 0: oldest
  void open_minute(std::int64_t minute) noexcept;         // advances the bucket ring

  std::size_t fine_capacity_;
  std::size_t minute_capacity_;
  std::vector<Sample> fine_;  // ring once full; fine_head_ is the oldest
  std::size_t fine_head_ = 0;
  std::vector<Bucket> minutes_;  // ring once full; minute_head_ is the oldest
  std::size_t minute_head_ = 0;
  std::int64_t last_minute_ = 0;  // minute index (t_ms / kMinuteMs) of the newest bucket
  std::int64_t last_t_ms_ = 0;
  std::int64_t evicted_t_ms_ = 0;  // the newest sample the fine ring overwrote
  bool evicted_ = false;
  bool empty_ = true;
  std::uint64_t dropped_ = 0;
};

}  // namespace hvac_twin::web
