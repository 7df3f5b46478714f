// The steady windows hvac-twin-calibrate fits (daemon/calibration/steady_windows.hpp).
#include "daemon/calibration/steady_windows.hpp"

#include <catch2/catch.hpp>
#include <cmath>
#include <limits>

namespace {

using hvac_twin::calibration::WindowFinder;
using hvac_twin::calibration::WindowOptions;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Two inputs (tolerance 1 and 0.5), two outputs, period 10 s, settle 100 s, windows >= 200 s.
WindowFinder finder(std::size_t min_samples = 5) {
  return WindowFinder({1.0, 0.5}, 2, 10.0, WindowOptions{100.0, 200.0, min_samples});
}

}  // namespace

TEST_CASE("a held operating point is one window after its settling time, with the means",
          "[calibration]") {
  auto f = finder();
  for (int k = 0; k < 60; ++k)  // 600 s; inputs wobble within tolerance
    f.add(10.0 * k, {50.0 + 0.4 * (k % 2), 3.0}, {100.0 + (k % 2), 7.0});
  const auto w = f.finish();
  REQUIRE(w.size() == 1);
  CHECK(f.segments() == 1);
  CHECK(w[0].start_s == 100.0);
  CHECK(w[0].end_s == 590.0);
  CHECK(w[0].cycles == 50);
  CHECK(w[0].u[0] == Approx(50.2));
  CHECK(w[0].y[0] == Approx(100.5));
  CHECK(w[0].y[1] == 7.0);
}

TEST_CASE("an input change, a missing input or a gap ends a segment, and a short rest is no window",
          "[calibration]") {
  auto f = finder();
  double t = 0.0;
  auto hold = [&](double u0, double seconds) {
    for (double end = t + seconds; t < end; t += 10.0)
      f.add(t, {u0, 3.0}, {1.0, 2.0});
  };
  hold(50.0, 400.0);                  // window 100-390 s
  hold(52.0, 250.0);                  // moved beyond 1: settles 100 s, then 150 s < 200 s: none
  f.add(t, {kNaN, 3.0}, {1.0, 2.0});  // a missing input ends it
  t += 10.0;
  hold(40.0, 400.0);  // 660-1050: window 760-1050
  t += 100.0;         // a gap of 10 periods
  hold(40.0, 400.0);  // 1160-1550: window 1260-1550
  const auto w = f.finish();
  CHECK(f.segments() == 4);
  REQUIRE(w.size() == 3);
  CHECK(w[0].start_s == 100.0);
  CHECK(w[0].end_s == 390.0);
  CHECK(w[1].u[0] == 40.0);
  CHECK(w[1].start_s == 760.0);
  CHECK(w[2].start_s == 1260.0);
}

TEST_CASE("an output read too rarely in a window is not measured there", "[calibration]") {
  auto f = finder(10);
  for (int k = 0; k < 40; ++k)  // 30 cycles in the window; y[1] GOOD in 9 of them
    f.add(10.0 * k, {50.0, 3.0}, {1.0, k >= 31 ? 2.0 : kNaN});
  const auto w = f.finish();
  REQUIRE(w.size() == 1);
  CHECK(w[0].y[0] == 1.0);
  CHECK(std::isnan(w[0].y[1]));
}
