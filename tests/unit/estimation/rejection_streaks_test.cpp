// RejectionStreaks: the per-slot rejection count and re-admission schedule both filters share.
#include "daemon/estimation/rejection_streaks.hpp"

#include <catch2/catch.hpp>
#include <vector>

using hvac_twin::est::RejectionStreaks;

TEST_CASE("a streak counts rejections in a row and knows whether its reading moved",
          "[estimator][readmission]") {
  RejectionStreaks s;
  s.resize(2);
  for (int k = 0; k < 4; ++k)
    s.reject(0, 21.5);  // frozen
  CHECK(s.count(0) == 4);
  CHECK_FALSE(s.varied(0));
  CHECK(s.faulty(0, 4));
  CHECK_FALSE(s.faulty(0, 5));
  s.arm_now(0, 5);  // a frozen reading is not armed
  CHECK_FALSE(s.armed(0));
  s.reject(0, 21.6);
  CHECK(s.varied(0));
  CHECK(s.count(1) == 0);  // slots are independent
  s.accept(0);
  CHECK(s.count(0) == 0);
  s.reject(0, 30.0);  // a new streak forgets the old one's movement
  CHECK_FALSE(s.varied(0));
}

TEST_CASE("a lone point is tested now, then ever more rarely", "[estimator][readmission]") {
  RejectionStreaks s;
  s.resize(1);
  const int max = 5;
  for (int k = 0; k < max; ++k)
    s.reject(0, 20.0 + k);
  s.arm_now(0, max);
  REQUIRE(s.armed(0));
  std::vector<int> tests;
  for (int k = max; k < 200; ++k) {
    if (s.take_due(0)) tests.push_back(s.count(0));
    s.reject(0, 20.0 + k);
  }
  // Due at the 5th rejection, then 10, 20, 40, 80 rejections later.
  CHECK(tests == std::vector<int>{5, 15, 35, 75, 155});
  s.disarm(0);
  CHECK_FALSE(s.take_due(0));
  s.clear();
  CHECK(s.count(0) == 0);
}

TEST_CASE("a point held out at a reset: armed for later, the back-off kept across a fusion",
          "[estimator][readmission]") {
  RejectionStreaks s;
  s.resize(1);
  s.set_count(0, 6);
  s.arm_later(0, 10);  // due 10 rejections from now
  CHECK_FALSE(s.take_due(0));
  for (int k = 0; k < 10; ++k)
    s.reject(0, 1.0 + k);
  CHECK(s.count(0) == 16);
  CHECK(s.take_due(0));  // the interval doubles to 20
  s.accept(0);
  s.keep_armed(0);  // let in by a reset: tested again 20 rejections after it falls out
  CHECK(s.armed(0));
  for (int k = 0; k < 19; ++k) {
    s.reject(0, 2.0 + k);
    CHECK_FALSE(s.take_due(0));
  }
  s.reject(0, 50.0);
  CHECK(s.take_due(0));
  s.disarm_keeping_backoff(0);
  CHECK_FALSE(s.armed(0));
  s.set_count(0, 0);
  s.arm_later(0, 1);  // the kept interval (40), not the smaller minimum
  for (int k = 0; k < 39; ++k) {
    s.reject(0, 3.0 + k);
    CHECK_FALSE(s.take_due(0));
  }
  s.reject(0, 99.0);
  CHECK(s.take_due(0));
}

TEST_CASE("re-armed with a back-off kept, a point is tested when its streak reaches it",
          "[estimator][readmission]") {
  RejectionStreaks s;
  s.resize(1);
  const int max = 5;
  const auto streak = [&](int n, double from) {
    for (int k = 0; k < n; ++k)
      s.reject(0, from + k);
  };
  streak(max, 1.0);
  s.arm_now(0, max);     // fresh: due now
  CHECK(s.take_due(0));  // the interval doubles to 10
  s.accept(0);
  s.disarm_keeping_backoff(0);  // fused between two streaks while the filter recovers
  streak(max, 2.0);
  s.arm_now(0, max);  // due at a streak of 10, not now
  CHECK(s.armed(0));
  for (int k = max; k < 10; ++k) {
    CHECK_FALSE(s.take_due(0));
    s.reject(0, 10.0 + k);
  }
  CHECK(s.count(0) == 10);
  CHECK(s.take_due(0));  // and 20 the next time
  s.accept(0);
  s.disarm(0);  // fused by the gate once recovered: the back-off forgotten
  streak(max, 3.0);
  s.arm_now(0, max);
  CHECK(s.take_due(0));
}
