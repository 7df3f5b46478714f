// The Store (io/web/store.hpp): what it keeps per unit, the bounds it enforces, and when a unit
// is stale (liveliness lost; no sample within 2.5 x its learnt period).
#include <catch2/catch.hpp>

#include "io/web/store.hpp"
#include "web_test_support.hpp"

using namespace hvac_twin;
using namespace hvac_twin::web;
using namespace hvac_twin::web::test;

TEST_CASE("store: records land in their unit, with a series per value", "[web][store]") {
  Store store;
  bool changed = false;
  CHECK(store.ingest(sensor("hp1", "superheat", 6.0, 0.5, kStamp0), 0, &changed) == 0);
  CHECK(changed);  // a new unit: its tile appears
  CHECK(store.ingest(observation("hp1", "suction_pressure", kStamp0), 0, &changed) == 0);
  CHECK_FALSE(changed);  // a point's values do not change the tile
  CHECK(store.ingest(health("hp1", 1, kStamp0), 0, &changed) == 0);
  CHECK(changed);
  CHECK(store.ingest(leak("hp1", dds::LeakState::kSuspect, kStamp0), 0, &changed) == 0);
  CHECK(changed);
  CHECK(store.ingest(health("hp2", 1, kStamp0), 0) == 1);
  REQUIRE(store.size() == 2);
  const UnitState& u = store.unit(0);
  CHECK(u.site == "site");
  CHECK(u.unit == "hp1");
  REQUIRE(u.sensors.size() == 1);
  CHECK(u.sensors[0].value == 6.0);
  REQUIRE(u.leak.has_value());
  CHECK(u.leak->state == dds::LeakState::kSuspect);
  for (const char* key : {"vs/superheat", "obs/suction_pressure/innovation",
                          "obs/suction_pressure/test_ratio", "health/cycle_time_ms", "leak/charge",
                          "leak/leak_rate", "leak/rate_cusum", "leak/charge_cusum"}) {
    INFO(key);
    CHECK(u.find_series(key) != nullptr);
  }
  // The innovation's sigma is the square root of its variance.
  const auto w = u.find_series("obs/suction_pressure/innovation")
                     ->series.window(kStamp0 / 1'000'000, 60'000, 10);
  REQUIRE(w.points.size() == 1);
  CHECK(w.points[0].sigma == Approx(2.0));
  CHECK(store.find("site", "hp2") == 1);
  CHECK(store.find("site", "hp3") == -1);
}

TEST_CASE("store: the unit estimate puts the sensors in the model's order", "[web][store]") {
  Store store;
  store.ingest(sensor("hp1", "cop", 3.0, 0.1, kStamp0), 0);
  store.ingest(sensor("hp1", "superheat", 6.0, 0.5, kStamp0), 0);
  dds::UnitEstimateRecord e;
  e.site = std::string("site");
  e.unit = std::string("hp1");
  e.quality = dds::EstimateQuality::kDegraded;
  e.flags = dds::kFlagColdStart;
  e.timestamp_ns = kStamp0 + kSecond;
  e.estimates = {
      {"superheat", 6.5, 0.5, "K"}, {"subcooling", 4.0, 0.3, "K"}, {"cop", 3.1, 0.1, "1"}};
  bool changed = false;
  store.ingest(e, 0, &changed);
  CHECK(changed);
  const UnitState& u = store.unit(0);
  REQUIRE(u.sensors.size() == 3);
  CHECK(u.sensors[0].name == "superheat");
  CHECK(u.sensors[0].value == 6.5);
  CHECK(u.sensors[1].name == "subcooling");
  CHECK(u.sensors[2].name == "cop");
  REQUIRE(u.estimate.has_value());
  CHECK(u.estimate->estimates.empty());  // kept once, in the sensors
  CHECK(u.estimate->flags == dds::kFlagColdStart);
  CHECK(u.find_series("vs/subcooling") != nullptr);
}

TEST_CASE("store: stale past 2.5 periods without a sample, or when liveliness is lost",
          "[web][store]") {
  Store store;
  std::vector<int> changed;
  // No period known yet: never stale by deadline.
  store.ingest(health("hp1", 10, kStamp0), 0);
  store.check_deadlines(3600 * kSecond, changed);
  CHECK(changed.empty());
  CHECK(store.unit(0).stale == Stale::kNo);
  // Two health samples 5 s apart over one cycle... and over two cycles (a skipped tick): 5 s.
  store.ingest(health("hp1", 11, kStamp0 + 5 * kSecond), 100 * kSecond);
  CHECK(store.unit(0).period_ns == 5 * kSecond);
  store.ingest(health("hp1", 13, kStamp0 + 15 * kSecond), 110 * kSecond);
  CHECK(store.unit(0).period_ns == 5 * kSecond);
  CHECK(store.unit(0).deadline_ns() == 12'500'000'000);
  CHECK(store.next_deadline() == 110 * kSecond + 12'500'000'000 + 1);

  store.check_deadlines(110 * kSecond + 12'400'000'000, changed);
  CHECK(changed.empty());
  store.check_deadlines(110 * kSecond + 12'600'000'000, changed);
  REQUIRE(changed == std::vector<int>{0});
  CHECK(store.unit(0).stale == Stale::kDeadline);
  CHECK(store.next_deadline() == std::numeric_limits<std::int64_t>::max());
  // A sample revives it, and says the tile changed.
  bool tile = false;
  store.ingest(observation("hp1", "p", kStamp0 + 20 * kSecond), 125 * kSecond, &tile);
  CHECK(tile);
  CHECK(store.unit(0).stale == Stale::kNo);

  // Liveliness lost: stale at once, and the deadline check does not clear it.
  CHECK(store.mark_liveliness_lost("site", "hp1") == 0);
  CHECK(store.mark_liveliness_lost("site", "hp1") == -1);  // already so
  CHECK(store.mark_liveliness_lost("site", "nope") == -1);
  CHECK(store.unit(0).stale == Stale::kLiveliness);
  changed.clear();
  store.check_deadlines(126 * kSecond, changed);
  CHECK(changed.empty());
  CHECK(store.unit(0).stale == Stale::kLiveliness);
  store.ingest(health("hp1", 14, kStamp0 + 25 * kSecond), 127 * kSecond);
  CHECK(store.unit(0).stale == Stale::kNo);

  // No live writer at all: every unit.
  store.ingest(health("hp2", 1, kStamp0), 127 * kSecond);
  store.mark_all_liveliness_lost(changed);
  CHECK(changed == std::vector<int>{0, 1});
  CHECK(store.unit(1).stale == Stale::kNoPublisher);
  CHECK(to_string(Stale::kNoPublisher) == "NO_PUBLISHER");
}

TEST_CASE("store: units, keys and series beyond the limits are refused and counted",
          "[web][store]") {
  StoreLimits limits;
  limits.max_units = 2;
  limits.max_keys_per_unit = 3;
  limits.max_series_per_unit = 4;
  limits.fine_capacity = 16;
  limits.minute_capacity = 10;
  Store store(limits);
  CHECK(store.ingest(health("a", 1, kStamp0), 0) == 0);
  CHECK(store.ingest(health("b", 1, kStamp0), 0) == 1);
  CHECK(store.ingest(health("c", 1, kStamp0), 0) == -1);
  CHECK(store.size() == 2);
  CHECK(store.counters().refused_units == 1);
  // Unit a has one series (cycle time); three sensors fill its keys and series.
  for (const char* name : {"s1", "s2", "s3"})
    CHECK(store.ingest(sensor("a", name, 1.0, 0.1, kStamp0), 0) == 0);
  CHECK(store.ingest(sensor("a", "s4", 1.0, 0.1, kStamp0), 0) == -1);
  CHECK(store.counters().refused_keys == 1);
  CHECK(store.unit(0).sensors.size() == 3);
  // A known key still updates.
  CHECK(store.ingest(sensor("a", "s1", 2.0, 0.1, kStamp0 + kSecond), 0) == 0);
  CHECK(store.unit(0).sensors[0].value == 2.0);
  // The leak diagnosis needs four more series: the unit has room for none.
  store.ingest(leak("a", dds::LeakState::kNormal, kStamp0), 0);
  CHECK(store.unit(0).series.size() == 4);
  CHECK(store.counters().refused_series == 4);
  // The budget: every bound reached.
  CHECK(store.history_budget_bytes() == 2 * 4 * Series::bytes_for(16, 10));
}
