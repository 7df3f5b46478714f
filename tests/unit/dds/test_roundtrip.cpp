// Every field of every sample type goes through a real Cyclone writer and reader unchanged.
#include <algorithm>
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <string>

#include "dds_test_support.hpp"
#include "io/dds/publisher.hpp"
#include "io/dds/subscriber.hpp"

using namespace hvac_twin::dds;
using namespace std::chrono_literals;

namespace {
constexpr int kDomainRoundTrip = 104;
constexpr int kDomainTwoUnits = 111;
constexpr int kDomainLeakRoundTrip = 117;
constexpr int kDomainConsistencyRoundTrip = 120;
}  // namespace

TEST_CASE("every field of every sample type round-trips", "[dds][roundtrip]") {
  const auto config = test::loopback_config(kDomainRoundTrip);
  Participant writer_side(config);
  Participant reader_side(config);
  const std::string site(kMaxNameLength, 's');  // the longest accepted key
  UnitPublisher publisher(writer_side, config.topic_prefix, site, "hp-1", 1s);
  Subscriber subscriber(reader_side, config.topic_prefix, {}, 1s);

  const std::int64_t t0 = test::now_ns();
  const std::string longest_unit(kMaxEngUnitLength, 'u');
  const std::string longest_point(kMaxNameLength, 'p');
  VirtualSensorSample vs;
  vs.name = "condenser_outlet_pressure";
  vs.value = 2.4567890123456789e6;
  vs.sigma = 1234.5;
  vs.eng_unit = longest_unit;
  vs.quality = EstimateQuality::kDegraded;
  vs.flags = kFlagPredictOnly | kFlagInputHeld | kFlagDeadlineOverrun;
  vs.timestamp_ns = t0;
  vs.cycle = 0xFFFF'FFFF'FFFF'FFF0ull;

  ObservationSample obs;
  obs.point = longest_point;
  obs.value = -12.25;
  obs.quality = PointQuality::kDeviceException;
  obs.exception_code = 0x0B;
  obs.predicted = -12.5;
  obs.innovation = 0.25;
  obs.innovation_variance = std::numeric_limits<double>::denorm_min();
  obs.test_ratio = 1e300;
  obs.fused = true;
  obs.timestamp_ns = t0 + 1;
  obs.cycle = 7;

  // One refused sample first: health must report it in publish_rejections.
  VirtualSensorSample nan_sample = vs;
  nan_sample.value = std::nan("");
  REQUIRE(publisher.publish(nan_sample) == PublishStatus::kNonFinite);

  const std::string long_error(200, 'e');
  HealthSample health;
  health.cycle = 123456789012ull;
  health.cycle_time_ms = 3.25;
  health.cycle_time_max_ms = 17.5;
  health.overruns = 1;
  health.degraded_cycles = 2;
  health.gate_rejections = 3;
  health.numerical_resets = 4;
  health.quality = EstimateQuality::kGood;
  health.modbus_connected = true;
  health.modbus_polls_ok = 5;
  health.modbus_polls_exception = 7;
  health.modbus_polls_failed = 6;
  health.modbus_reconnects = 8;
  health.modbus_last_error = long_error;
  health.timestamp_ns = t0 + 2;

  REQUIRE(publisher.publish(vs) == PublishStatus::kOk);
  REQUIRE(publisher.publish(obs) == PublishStatus::kOk);
  REQUIRE(publisher.publish(health) == PublishStatus::kOk);
  CHECK(publisher.stats().published == 3);

  std::vector<Record> records;
  REQUIRE(test::collect(subscriber, records, 3));
  REQUIRE(records.size() == 3);

  const auto vss = test::only<VirtualSensorRecord>(records);
  REQUIRE(vss.size() == 1);
  const VirtualSensorRecord& v = vss[0];
  CHECK(v.site == site);
  CHECK(v.unit == "hp-1");
  CHECK(v.name == vs.name);
  CHECK(v.value == vs.value);  // bit-exact
  CHECK(v.sigma == vs.sigma);
  CHECK(v.eng_unit == vs.eng_unit);
  CHECK(v.quality == EstimateQuality::kDegraded);
  CHECK(v.flags == vs.flags);
  CHECK(v.timestamp_ns == t0);
  CHECK(v.source_timestamp_ns == t0);  // written with dds_write_ts
  CHECK(v.cycle == vs.cycle);

  const auto observations = test::only<ObservationRecord>(records);
  REQUIRE(observations.size() == 1);
  const ObservationRecord& o = observations[0];
  CHECK(o.site == site);
  CHECK(o.unit == "hp-1");
  CHECK(o.point == obs.point);
  CHECK(o.value == obs.value);
  CHECK(o.quality == PointQuality::kDeviceException);
  CHECK(o.exception_code == 0x0B);
  CHECK(o.predicted == obs.predicted);
  CHECK(o.innovation == obs.innovation);
  CHECK(o.innovation_variance == obs.innovation_variance);
  CHECK(o.test_ratio == obs.test_ratio);
  CHECK(o.fused);
  CHECK(o.timestamp_ns == t0 + 1);
  CHECK(o.source_timestamp_ns == t0 + 1);
  CHECK(o.cycle == 7);

  const auto healths = test::only<HealthRecord>(records);
  REQUIRE(healths.size() == 1);
  const HealthRecord& h = healths[0];
  CHECK(h.site == site);
  CHECK(h.unit == "hp-1");
  CHECK(h.cycle == health.cycle);
  CHECK(h.cycle_time_ms == 3.25);
  CHECK(h.cycle_time_max_ms == 17.5);
  CHECK(h.overruns == 1);
  CHECK(h.degraded_cycles == 2);
  CHECK(h.gate_rejections == 3);
  CHECK(h.numerical_resets == 4);
  CHECK(h.publish_rejections == 1);  // the NaN sample above
  CHECK(h.quality == EstimateQuality::kGood);
  CHECK(h.modbus_connected);
  CHECK(h.modbus_polls_ok == 5);
  CHECK(h.modbus_polls_exception == 7);
  CHECK(h.modbus_polls_failed == 6);
  CHECK(h.modbus_reconnects == 8);
  // Free text is cut visibly, never silently.
  CHECK(h.modbus_last_error.size() == kMaxErrorTextLength);
  CHECK(h.modbus_last_error == std::string(kMaxErrorTextLength - 3, 'e') + "...");
  CHECK(h.timestamp_ns == t0 + 2);
  CHECK(h.source_timestamp_ns == t0 + 2);

  // Every enumerator survives the wire.
  records.clear();
  for (int q = 0; q <= 5; ++q) {
    obs.quality = static_cast<PointQuality>(q);
    const std::string point = "q" + std::to_string(q);
    obs.point = point;
    REQUIRE(publisher.publish(obs) == PublishStatus::kOk);
  }
  for (int q = 0; q <= 2; ++q) {
    vs.quality = static_cast<EstimateQuality>(q);
    const std::string name = "e" + std::to_string(q);
    vs.name = name;
    REQUIRE(publisher.publish(vs) == PublishStatus::kOk);
  }
  REQUIRE(test::collect(subscriber, records, 9));
  for (const auto& r : test::only<ObservationRecord>(records)) {
    CHECK(r.point == "q" + std::to_string(static_cast<int>(r.quality)));
  }
  for (const auto& r : test::only<VirtualSensorRecord>(records)) {
    CHECK(r.name == "e" + std::to_string(static_cast<int>(r.quality)));
  }
}

TEST_CASE("two units publish side by side on one participant", "[dds][roundtrip]") {
  const auto config = test::loopback_config(kDomainTwoUnits);
  Participant participant(config);
  UnitPublisher hp1(participant, config.topic_prefix, "site", "hp1", 1s);
  UnitPublisher hp2(participant, config.topic_prefix, "site", "hp2", 1s);
  Subscriber subscriber(participant, config.topic_prefix, {false, false, true, false, false});

  HealthSample health;
  health.timestamp_ns = test::now_ns();
  health.cycle = 1;
  REQUIRE(hp1.publish(health) == PublishStatus::kOk);
  health.cycle = 2;
  REQUIRE(hp2.publish(health) == PublishStatus::kOk);

  std::vector<Record> records;
  REQUIRE(test::collect(subscriber, records, 2));
  auto healths = test::only<HealthRecord>(records);
  REQUIRE(healths.size() == 2);
  std::sort(healths.begin(), healths.end(),
            [](const auto& a, const auto& b) { return a.unit < b.unit; });
  CHECK(healths[0].unit == "hp1");
  CHECK(healths[0].cycle == 1);
  CHECK(healths[1].unit == "hp2");
  CHECK(healths[1].cycle == 2);
}

TEST_CASE("the leak diagnostic and the fused-points provenance round-trip", "[dds][roundtrip]") {
  const auto config = test::loopback_config(kDomainLeakRoundTrip);
  Participant writer_side(config);
  Participant reader_side(config);
  UnitPublisher publisher(writer_side, config.topic_prefix, "site", "hp-1", 1s);
  Subscriber subscriber(reader_side, config.topic_prefix, {}, 1s);
  const std::int64_t t0 = test::now_ns();

  LeakDiagnosticSample leak;
  leak.state = LeakState::kSuspect;
  leak.hold = LeakHold::kCycling;
  leak.charge = 0.4871234;
  leak.charge_sigma = 0.0042;
  leak.nameplate_charge = 0.5;
  leak.leak_rate = 2.0833;
  leak.leak_rate_sigma = 0.61;
  leak.cusum = 7.25;
  leak.rate_cusum = 1.5;
  leak.charge_cusum = 7.25;
  leak.charge_reference = 0.5204;
  leak.threshold = 12.5;
  leak.false_alarm_interval_days = 3650.0;
  leak.decisions = 99;
  leak.suspect_since_ns = t0 - 5;
  leak.leak_since_ns = 0;
  leak.quality = EstimateQuality::kGood;
  leak.timestamp_ns = t0;
  leak.cycle = 1234;
  REQUIRE(publisher.publish(leak) == PublishStatus::kOk);

  VirtualSensorSample vs;
  vs.name = "charge";
  vs.value = 0.49;
  vs.eng_unit = "kg";
  vs.fused_points = 0x8000'0000'0000'0005ull;  // points 0, 2 and 63
  vs.timestamp_ns = t0;
  REQUIRE(publisher.publish(vs) == PublishStatus::kOk);

  std::vector<Record> records;
  REQUIRE(test::collect(subscriber, records, 2));
  const auto leaks = test::only<LeakDiagnosticRecord>(records);
  REQUIRE(leaks.size() == 1);
  const LeakDiagnosticRecord& l = leaks[0];
  CHECK(l.site == "site");
  CHECK(l.unit == "hp-1");
  CHECK(l.state == LeakState::kSuspect);
  CHECK(l.hold == LeakHold::kCycling);
  CHECK(l.charge == leak.charge);
  CHECK(l.charge_sigma == leak.charge_sigma);
  CHECK(l.nameplate_charge == 0.5);
  CHECK(l.leak_rate == leak.leak_rate);
  CHECK(l.leak_rate_sigma == leak.leak_rate_sigma);
  CHECK(l.cusum == 7.25);
  CHECK(l.rate_cusum == 1.5);
  CHECK(l.charge_cusum == 7.25);
  CHECK(l.charge_reference == 0.5204);
  CHECK(l.threshold == 12.5);
  CHECK(l.false_alarm_interval_days == 3650.0);
  CHECK(l.decisions == 99);
  CHECK(l.suspect_since_ns == t0 - 5);
  CHECK(l.leak_since_ns == 0);
  CHECK(l.quality == EstimateQuality::kGood);
  CHECK(l.timestamp_ns == t0);
  CHECK(l.source_timestamp_ns == t0);
  CHECK(l.cycle == 1234);
  const auto vss = test::only<VirtualSensorRecord>(records);
  REQUIRE(vss.size() == 1);
  CHECK(vss[0].fused_points == vs.fused_points);

  // Every alarm state and hold reason survives the wire (keep-last 1: read each before the next).
  for (int s = 0; s <= 2; ++s) {
    for (int h = 0; h <= 5; ++h) {
      leak.state = static_cast<LeakState>(s);
      leak.hold = static_cast<LeakHold>(h);
      REQUIRE(publisher.publish(leak) == PublishStatus::kOk);
      records.clear();
      REQUIRE(test::collect(subscriber, records, 1));
      const auto got = test::only<LeakDiagnosticRecord>(records);
      REQUIRE(got.size() == 1);
      CHECK(got[0].state == leak.state);
      CHECK(got[0].hold == leak.hold);
    }
  }

  // The publisher's guard: nothing non-finite or negative where it cannot be.
  LeakDiagnosticSample bad = leak;
  bad.charge = std::nan("");
  CHECK(publisher.publish(bad) == PublishStatus::kNonFinite);
  bad = leak;
  bad.leak_rate_sigma = -1.0;
  CHECK(publisher.publish(bad) == PublishStatus::kInvalidValue);
  bad = leak;
  bad.charge_cusum = -0.5;
  CHECK(publisher.publish(bad) == PublishStatus::kInvalidValue);
  bad = leak;
  bad.charge_reference = std::numeric_limits<double>::infinity();
  CHECK(publisher.publish(bad) == PublishStatus::kNonFinite);
  bad = leak;
  bad.leak_since_ns = -1;
  CHECK(publisher.publish(bad) == PublishStatus::kInvalidTimestamp);
  CHECK(publisher.stats().rejected() == 5);
}

TEST_CASE("the estimator consistency round-trips, keyed by point, and is guarded",
          "[dds][roundtrip]") {
  const auto config = test::loopback_config(kDomainConsistencyRoundTrip);
  Participant writer_side(config);
  Participant reader_side(config);
  UnitPublisher publisher(writer_side, config.topic_prefix, "site", "hp-1", 1s);
  Subscriber subscriber(reader_side, config.topic_prefix,
                        TopicSet{false, false, false, false, true, false}, 1s);
  const std::int64_t t0 = test::now_ns();

  ConsistencySample point;
  point.point = "suction_pressure";
  point.window_cycles = 360;
  point.samples = 355;
  point.mean_nis = 4.123456789;
  point.band_low = 0.8567;
  point.band_high = 1.1523;
  point.verdict = ConsistencyVerdict::kHigh;
  point.rejected_share = 0.125;
  point.timestamp_ns = t0;
  point.cycle = 4242;
  ConsistencySample all = point;
  all.point = kAllPoints;
  all.samples = 4294967295u;  // the largest count the wire holds
  all.verdict = ConsistencyVerdict::kInBand;
  REQUIRE(publisher.publish(point) == PublishStatus::kOk);
  REQUIRE(publisher.publish(all) == PublishStatus::kOk);

  std::vector<Record> records;
  REQUIRE(test::collect(subscriber, records, 2));
  auto got = test::only<ConsistencyRecord>(records);
  REQUIRE(got.size() == 2);
  std::sort(got.begin(), got.end(), [](const auto& a, const auto& b) { return a.point < b.point; });
  CHECK(got[0].point == "*");  // two keys, two instances
  CHECK(got[0].samples == 4294967295u);
  CHECK(got[0].verdict == ConsistencyVerdict::kInBand);
  const ConsistencyRecord& c = got[1];
  CHECK(c.site == "site");
  CHECK(c.unit == "hp-1");
  CHECK(c.point == "suction_pressure");
  CHECK(c.window_cycles == 360);
  CHECK(c.samples == 355);
  CHECK(c.mean_nis == point.mean_nis);  // bit-exact
  CHECK(c.band_low == point.band_low);
  CHECK(c.band_high == point.band_high);
  CHECK(c.verdict == ConsistencyVerdict::kHigh);
  CHECK(c.rejected_share == 0.125);
  CHECK(c.timestamp_ns == t0);
  CHECK(c.source_timestamp_ns == t0);
  CHECK(c.cycle == 4242);

  // Every verdict survives the wire (keep-last 1: read each before the next).
  for (int v = 0; v <= 3; ++v) {
    point.verdict = static_cast<ConsistencyVerdict>(v);
    REQUIRE(publisher.publish(point) == PublishStatus::kOk);
    records.clear();
    REQUIRE(test::collect(subscriber, records, 1));
    const auto one = test::only<ConsistencyRecord>(records);
    REQUIRE(one.size() == 1);
    CHECK(one[0].verdict == point.verdict);
    CHECK(to_string(one[0].verdict) ==
          std::array{"INSUFFICIENT_DATA", "IN_BAND", "HIGH", "LOW"}[v]);
  }

  // The publisher's guard: nothing non-finite, negative, or a share above 1; a key that fits.
  ConsistencySample bad = point;
  bad.mean_nis = std::nan("");
  CHECK(publisher.publish(bad) == PublishStatus::kNonFinite);
  bad = point;
  bad.band_high = std::numeric_limits<double>::infinity();
  CHECK(publisher.publish(bad) == PublishStatus::kNonFinite);
  bad = point;
  bad.band_low = -0.1;
  CHECK(publisher.publish(bad) == PublishStatus::kInvalidValue);
  bad = point;
  bad.rejected_share = 1.5;
  CHECK(publisher.publish(bad) == PublishStatus::kInvalidValue);
  bad = point;
  bad.point = "";
  CHECK(publisher.publish(bad) == PublishStatus::kInvalidName);
  bad = point;
  bad.timestamp_ns = -1;
  CHECK(publisher.publish(bad) == PublishStatus::kInvalidTimestamp);
  CHECK(publisher.stats().rejected() == 6);
  CHECK(subscriber.wait_and_take(300ms, records) == 0);  // none of them reached the wire
}
