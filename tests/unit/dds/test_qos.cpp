// The state QoS: values composed from the period, and that writers and readers really use them.
#include <catch2/catch.hpp>
#include <chrono>

#include "dds_test_support.hpp"
#include "io/dds/publisher.hpp"
#include "io/dds/qos.hpp"
#include "io/dds/subscriber.hpp"

using namespace hvac_twin::dds;
using namespace std::chrono_literals;

namespace {
constexpr int kDomainMatch = 103;
}

TEST_CASE("state QoS: deadline 2.5 x period, MANUAL_BY_TOPIC lease 3 x period", "[dds][qos]") {
  STATIC_REQUIRE(state_deadline(1s) == 2500ms);
  STATIC_REQUIRE(state_liveliness_lease(1s) == 3s);
  STATIC_REQUIRE(state_deadline(10s) == 25s);
  STATIC_REQUIRE(state_liveliness_lease(10s) == 30s);

  const QosPtr qos = make_state_qos(10s);
  REQUIRE(qos);

  dds_reliability_kind_t reliability{};
  dds_duration_t max_blocking = 0;
  REQUIRE(dds_qget_reliability(qos.get(), &reliability, &max_blocking));
  CHECK(reliability == DDS_RELIABILITY_RELIABLE);
  CHECK(max_blocking == std::chrono::nanoseconds(kMaxBlockingTime).count());

  dds_durability_kind_t durability{};
  REQUIRE(dds_qget_durability(qos.get(), &durability));
  CHECK(durability == DDS_DURABILITY_TRANSIENT_LOCAL);

  dds_history_kind_t history{};
  int32_t depth = 0;
  REQUIRE(dds_qget_history(qos.get(), &history, &depth));
  CHECK(history == DDS_HISTORY_KEEP_LAST);
  CHECK(depth == 1);

  dds_duration_t cleanup = 0;
  int32_t max_samples = 0, max_instances = 0, max_per_instance = 0;
  REQUIRE(dds_qget_durability_service(qos.get(), &cleanup, &history, &depth, &max_samples,
                                      &max_instances, &max_per_instance));
  CHECK(history == DDS_HISTORY_KEEP_LAST);
  CHECK(depth == 1);

  dds_duration_t deadline = 0;
  REQUIRE(dds_qget_deadline(qos.get(), &deadline));
  CHECK(deadline == 25'000'000'000);

  dds_liveliness_kind_t liveliness{};
  dds_duration_t lease = 0;
  REQUIRE(dds_qget_liveliness(qos.get(), &liveliness, &lease));
  CHECK(liveliness == DDS_LIVELINESS_MANUAL_BY_TOPIC);
  CHECK(lease == 30'000'000'000);
}

TEST_CASE("state QoS for a reader of any period requests nothing a writer cannot offer",
          "[dds][qos]") {
  const QosPtr qos = make_state_qos(kAnyPeriod);
  dds_duration_t deadline = 0;
  REQUIRE(dds_qget_deadline(qos.get(), &deadline));
  CHECK(deadline == DDS_INFINITY);
  dds_liveliness_kind_t liveliness{};
  dds_duration_t lease = 0;
  REQUIRE(dds_qget_liveliness(qos.get(), &liveliness, &lease));
  CHECK(liveliness == DDS_LIVELINESS_AUTOMATIC);
  CHECK(lease == DDS_INFINITY);
  dds_durability_kind_t durability{};
  REQUIRE(dds_qget_durability(qos.get(), &durability));
  CHECK(durability == DDS_DURABILITY_TRANSIENT_LOCAL);
}

TEST_CASE("state QoS refuses a negative or absurd period", "[dds][qos]") {
  CHECK_THROWS_AS(make_state_qos(-1ns), std::invalid_argument);
  CHECK_THROWS_AS(make_state_qos(25h), std::invalid_argument);
}

TEST_CASE("writers offer the state QoS: matching and non-matching readers", "[dds][qos]") {
  Participant participant(test::loopback_config(kDomainMatch));
  const auto prefix = test::loopback_config(kDomainMatch).topic_prefix;
  UnitPublisher publisher(participant, prefix, "site", "hp1", 1s);

  // Same period, and "any period": both match every topic without a QoS conflict.
  Subscriber same(participant, prefix, {}, 1s);
  Subscriber any(participant, prefix);
  // A reader asking for a 1.25 s deadline cannot be served by a writer offering 2.5 s.
  Subscriber too_strict(participant, prefix, {}, 500ms);

  for (const Topic topic : kAllTopics) {
    INFO(topic_suffix(topic));
    CHECK(test::eventually([&] { return same.status(topic).matched_writers == 1; }));
    CHECK(test::eventually([&] { return any.status(topic).matched_writers == 1; }));
    CHECK(test::eventually([&] { return too_strict.status(topic).incompatible_qos >= 1; }));
    CHECK(same.status(topic).incompatible_qos == 0);
    CHECK(any.status(topic).incompatible_qos == 0);
    CHECK(too_strict.status(topic).matched_writers == 0);
  }
}
