// State semantics of the QoS: late joiners get the last sample per key at once, and a publisher
// that stops writing is noticed through the deadline and MANUAL_BY_TOPIC liveliness.
#include <algorithm>
#include <catch2/catch.hpp>
#include <map>
#include <thread>

#include "dds_test_support.hpp"
#include "io/dds/publisher.hpp"
#include "io/dds/subscriber.hpp"

using namespace hvac_twin::dds;
using namespace std::chrono_literals;

namespace {
constexpr int kDomainLateJoiner = 105;
constexpr int kDomainLiveliness = 108;
constexpr int kDomainAssert = 114;
constexpr int kDomainInstanceLost = 201;  // hvac-twin-web's range (200..209)

constexpr std::chrono::nanoseconds state_lease(std::chrono::nanoseconds period) {
  return 3 * period;  // io/dds/qos.hpp state_liveliness_lease, checked in test_qos.cpp
}
}  // namespace

TEST_CASE("a late-joining reader gets the last sample of every key immediately", "[dds][state]") {
  const auto config = test::loopback_config(kDomainLateJoiner);
  Participant participant(config);
  UnitPublisher publisher(participant, config.topic_prefix, "site", "hp1", 1s);

  const std::int64_t t = test::now_ns();
  VirtualSensorSample vs;
  vs.eng_unit = "Pa";
  vs.quality = EstimateQuality::kGood;
  for (std::uint64_t cycle = 1; cycle <= 5; ++cycle) {
    vs.cycle = cycle;
    vs.timestamp_ns = t + static_cast<std::int64_t>(cycle);
    vs.name = "condenser_pressure";
    vs.value = 1000.0 * static_cast<double>(cycle);
    REQUIRE(publisher.publish(vs) == PublishStatus::kOk);
    vs.name = "evaporator_pressure";
    vs.value = 10.0 * static_cast<double>(cycle);
    REQUIRE(publisher.publish(vs) == PublishStatus::kOk);
  }
  HealthSample health;
  health.cycle = 5;
  health.timestamp_ns = t + 5;
  REQUIRE(publisher.publish(health) == PublishStatus::kOk);

  // Joins after everything was written; a separate participant as a dashboard would be.
  Participant late_participant(config);
  Subscriber late(late_participant, config.topic_prefix);
  std::vector<Record> records;
  REQUIRE(test::collect(late, records, 3));
  // KEEP_LAST 1 per instance: nothing older than the last cycle arrives.
  CHECK(late.wait_and_take(300ms, records) == 0);
  REQUIRE(records.size() == 3);

  std::map<std::string, VirtualSensorRecord> by_name;
  for (const auto& r : test::only<VirtualSensorRecord>(records))
    by_name[r.name] = r;
  REQUIRE(by_name.size() == 2);
  CHECK(by_name["condenser_pressure"].value == 5000.0);
  CHECK(by_name["condenser_pressure"].cycle == 5);
  CHECK(by_name["evaporator_pressure"].value == 50.0);
  CHECK(test::only<HealthRecord>(records).at(0).cycle == 5);
}

TEST_CASE("a publisher that stops writing misses its deadline and loses liveliness",
          "[dds][state]") {
  const auto config = test::loopback_config(kDomainLiveliness);
  // A short period keeps the test quick: deadline 250 ms, lease 300 ms.
  constexpr auto kPeriod = 100ms;
  Participant participant(config);
  UnitPublisher publisher(participant, config.topic_prefix, "site", "hp1", kPeriod);
  Subscriber subscriber(participant, config.topic_prefix, {true, false, false}, kPeriod);

  VirtualSensorSample vs;
  vs.name = "zone_air_temperature";
  vs.timestamp_ns = test::now_ns();
  REQUIRE(publisher.publish(vs) == PublishStatus::kOk);
  std::vector<Record> records;
  REQUIRE(test::collect(subscriber, records, 1));

  // The "cycle" hangs: no more writes. Both mechanisms must report it.
  CHECK(test::eventually(
      [&] { return subscriber.status(Topic::kVirtualSensor).deadline_missed >= 1; }));
  CHECK(test::eventually(
      [&] { return subscriber.status(Topic::kVirtualSensor).alive_writers == 0; }));

  // Cycles complete again and write: the writer is alive again.
  CHECK(test::eventually([&] {
    vs.timestamp_ns = test::now_ns();
    REQUIRE(publisher.publish(vs) == PublishStatus::kOk);
    return subscriber.status(Topic::kVirtualSensor).alive_writers == 1;
  }));
}

TEST_CASE("assert_liveliness keeps a writer alive between writes", "[dds][state]") {
  const auto config = test::loopback_config(kDomainAssert);
  constexpr auto kPeriod = 400ms;  // lease 1.2 s: generous against scheduling delays
  Participant participant(config);
  UnitPublisher publisher(participant, config.topic_prefix, "site", "hp1", kPeriod);
  Subscriber subscriber(participant, config.topic_prefix, {true, false, false}, kPeriod);

  VirtualSensorSample vs;
  vs.name = "zone_air_temperature";
  vs.timestamp_ns = test::now_ns();
  REQUIRE(publisher.publish(vs) == PublishStatus::kOk);
  REQUIRE(test::eventually(
      [&] { return subscriber.status(Topic::kVirtualSensor).alive_writers == 1; }));

  // Three leases without a write, asserting liveliness as completed cycles would.
  const auto end = std::chrono::steady_clock::now() + 3 * state_lease(kPeriod);
  std::uint32_t min_alive = 1;
  while (std::chrono::steady_clock::now() < end) {
    REQUIRE(publisher.assert_liveliness() == PublishStatus::kOk);
    min_alive = std::min(min_alive, subscriber.status(Topic::kVirtualSensor).alive_writers);
    std::this_thread::sleep_for(kPeriod / 4);
  }
  CHECK(min_alive == 1);
  // The deadline is about updates, not liveliness: the unchanged instance missed it.
  CHECK(subscriber.status(Topic::kVirtualSensor).deadline_missed >= 1);
}

TEST_CASE("a reader learns which instances lost their writer's liveliness", "[dds][state]") {
  // hvac-twin-web marks a unit stale from these, per unit, even while other publishers live.
  const auto config = test::loopback_config(kDomainInstanceLost);
  constexpr auto kPeriod = 100ms;  // lease 300 ms
  Participant participant(config);
  UnitPublisher hp1(participant, config.topic_prefix, "site", "hp1", kPeriod);
  UnitPublisher hp2(participant, config.topic_prefix, "site", "hp2", kPeriod);
  Subscriber subscriber(participant, config.topic_prefix,
                        {false, false, true, false, false, false});

  HealthSample h;
  h.cycle = 1;
  h.timestamp_ns = test::now_ns();
  REQUIRE(hp1.publish(h) == PublishStatus::kOk);
  REQUIRE(hp2.publish(h) == PublishStatus::kOk);
  std::vector<Record> records;
  std::vector<InstanceLost> lost;
  REQUIRE(test::collect(subscriber, records, 2));

  // hp1 stops; hp2 keeps writing every period. Only hp1's instance is reported lost.
  const auto end = std::chrono::steady_clock::now() + test::kTimeout;
  while (lost.empty() && std::chrono::steady_clock::now() < end) {
    ++h.cycle;
    h.timestamp_ns = test::now_ns();
    REQUIRE(hp2.publish(h) == PublishStatus::kOk);
    REQUIRE(subscriber.wait_and_take(kPeriod, records, &lost) >= 0);
  }
  REQUIRE(lost.size() == 1);
  CHECK(lost[0].topic == Topic::kEstimatorHealth);
  CHECK(lost[0].site == "site");
  CHECK(lost[0].unit == "hp1");
  // (Cyclone reports it disposed: a writer that auto-disposes its instances, the default and the
  // daemon's, disposes them when its liveliness lapses too.)
  // Without the out-parameter the notifications are taken and dropped, as before.
  std::vector<Record> more;
  CHECK(subscriber.take(more) >= 0);
}
