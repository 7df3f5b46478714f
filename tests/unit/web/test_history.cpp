// The bounded history of one series (io/web/history.hpp): the rings never outgrow their
// capacity, the window comes from the fine ring while it reaches back far enough and otherwise
// from the minute buckets up to the fine ring's oldest sample and the fine ring after it, and
// downsampling keeps the mean and the envelope of the ±2σ band.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>

#include "io/web/history.hpp"

using hvac_twin::web::Series;
using hvac_twin::web::SeriesPoint;

namespace {
constexpr std::int64_t kT0 = 1'699'999'980'000;  // ms, on a minute boundary (2023-11-14)
static_assert(kT0 % Series::kMinuteMs == 0);
}  // namespace

TEST_CASE("history: both rings stay within their capacity however long it runs", "[web][history]") {
  Series s(100, 60);
  // Two days at 5 s: 34 560 samples.
  for (std::int64_t i = 0; i < 2 * 17'280; ++i)
    REQUIRE(s.add(kT0 + i * 5000, static_cast<double>(i), 1.0));
  CHECK(s.fine_size() == 100);
  CHECK(s.minute_size() == 60);
  CHECK(s.fine_capacity() == 100);
  CHECK(s.minute_capacity() == 60);
  // The fine ring holds the newest 100 samples, in order.
  const std::int64_t now = kT0 + (2 * 17'280 - 1) * 5000;
  const auto w = s.window(now, 100 * 5000 - 1, 1000);
  REQUIRE_FALSE(w.minute_resolution);
  REQUIRE(w.points.size() == 100);
  CHECK(w.points.front().value == 2 * 17'280 - 100);
  CHECK(w.points.back().value == 2 * 17'280 - 1);
  // Memory is fixed by the capacities.
  CHECK(Series::bytes_for(720, 1440) < 41'000);  // README: 41 KB per series
}

TEST_CASE("history: minute buckets keep the mean and the envelope of the 2-sigma band",
          "[web][history]") {
  Series s(8, 1440);
  // 12 samples in one minute (every 5 s): values 0..11, sigma 0.5, one outlier sigma of 3.
  for (int i = 0; i < 12; ++i)
    REQUIRE(s.add(kT0 + i * 5000, i, i == 7 ? 3.0 : 0.5));
  // And one sample in the next minute.
  REQUIRE(s.add(kT0 + Series::kMinuteMs + 1000, 100.0, 1.0));
  // A window longer than the fine ring reaches (8 samples): the minute before its oldest sample
  // from the bucket, then the 8 samples at full resolution.
  const auto w = s.window(kT0 + 2 * Series::kMinuteMs, 10 * Series::kMinuteMs, 100);
  REQUIRE(w.minute_resolution);
  REQUIRE(w.points.size() == 9);
  const SeriesPoint& m = w.points[0];
  CHECK(m.t_ms == kT0);
  CHECK(m.value == Approx(5.5));
  CHECK(m.sigma == Approx((11 * 0.5 + 3.0) / 12));
  CHECK(m.lo == Approx(0.0 - 2 * 0.5));  // min(v - 2s): sample 0
  CHECK(m.hi == Approx(7.0 + 2 * 3.0));  // max(v + 2s): the outlier's band, not the max value's
  CHECK(w.points[1].t_ms == kT0 + 5 * 5000);  // the oldest sample the fine ring kept
  CHECK(w.points[1].value == 5.0);
  CHECK(w.points[1].hi == Approx(6.0));
  CHECK(w.points.back().value == Approx(100.0));
  CHECK(w.points.back().t_ms == kT0 + Series::kMinuteMs + 1000);
}

TEST_CASE("history: a day of minutes at 5 s, asked for the last hour, the day, or in fewer points",
          "[web][history]") {
  Series s(720, 1440);
  const std::int64_t n = 17'280;  // a day at 5 s
  for (std::int64_t i = 0; i < n; ++i)
    REQUIRE(s.add(kT0 + i * 5000, std::sin(static_cast<double>(i) / 500.0), 0.1));
  const std::int64_t now = kT0 + n * 5000;
  // The last hour: the fine ring covers it (720 samples), at full resolution or merged 3 to 1.
  const auto hour = s.window(now, 3600 * 1000, 1000);
  CHECK_FALSE(hour.minute_resolution);
  CHECK(hour.points.size() == 720);
  const auto hour_300 = s.window(now, 3600 * 1000, 300);
  CHECK(hour_300.points.size() == 240);
  // The day: the 1381 minute buckets up to the fine ring's oldest sample, then its 720 samples;
  // or merged into at most 300 points whose band still contains every sample's band.
  const auto day = s.window(now, 86'400'000, 4000);
  CHECK(day.minute_resolution);
  REQUIRE(day.points.size() == 1381 + 720);
  CHECK(day.points[0].t_ms == kT0);
  CHECK(day.points[1380].t_ms == kT0 + 1380 * Series::kMinuteMs);
  CHECK(day.points[1381].t_ms == now - 720 * 5000);
  CHECK(day.points.back().t_ms == now - 5000);
  const auto day_300 = s.window(now, 86'400'000, 300);
  CHECK(day_300.points.size() <= 300);
  CHECK(day_300.points.size() >= 280);
  double lo = 0, hi = 0;
  for (const auto& p : day_300.points) {
    lo = std::min(lo, p.lo);
    hi = std::max(hi, p.hi);
  }
  CHECK(lo == Approx(-1.2).margin(1e-3));
  CHECK(hi == Approx(1.2).margin(1e-3));
}

TEST_CASE("history: gaps are empty minutes, old or repeated samples and NaN are dropped",
          "[web][history]") {
  Series s(4, 10);
  REQUIRE(s.add(kT0, 1.0, 0.1));
  CHECK_FALSE(s.add(kT0, 2.0, 0.1));         // the same time again (a duplicate)
  CHECK_FALSE(s.add(kT0 - 1000, 2.0, 0.1));  // older than the last
  CHECK_FALSE(s.add(kT0 + 1, std::numeric_limits<double>::quiet_NaN(), 0.1));
  CHECK_FALSE(s.add(kT0 + 1, 1.0, std::numeric_limits<double>::infinity()));
  CHECK(s.dropped() == 4);
  // Five minutes without data, then data: the gap is five empty buckets, not drawn.
  REQUIRE(s.add(kT0 + 6 * Series::kMinuteMs, 3.0, 0.1));
  CHECK(s.minute_size() == 7);
  for (int i = 1; i <= 4; ++i)
    REQUIRE(s.add(kT0 + 6 * Series::kMinuteMs + i, 3.0, 0.1));
  const auto w = s.window(kT0 + 7 * Series::kMinuteMs, 10 * Series::kMinuteMs, 100);
  REQUIRE(w.minute_resolution);
  REQUIRE(w.points.size() == 2 + 4);  // two buckets with data, the four samples the ring kept
  CHECK(w.points[0].t_ms == kT0);
  CHECK(w.points[1].t_ms == kT0 + 6 * Series::kMinuteMs);
  CHECK(w.points[2].t_ms == kT0 + 6 * Series::kMinuteMs + 1);
  // A gap longer than the whole ring starts it afresh.
  REQUIRE(s.add(kT0 + 100 * Series::kMinuteMs, 5.0, 0.1));
  CHECK(s.minute_size() == 1);
}
