// The publisher refuses non-finite numbers and bad names (counted, never on the wire) and
// refuses bad keys at creation.
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
constexpr int kDomainGuards = 106;
constexpr int kDomainCreation = 107;
constexpr int kDomainNames = 113;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

VirtualSensorSample good_vs(std::int64_t t) {
  VirtualSensorSample s;
  s.name = "zone_air_temperature";
  s.value = 21.43;
  s.sigma = 0.05;
  s.eng_unit = "degC";
  s.quality = EstimateQuality::kGood;
  s.timestamp_ns = t;
  return s;
}
}  // namespace

TEST_CASE("non-finite numbers are refused and counted and never published", "[dds][guards]") {
  const auto config = test::loopback_config(kDomainGuards);
  Participant participant(config);
  UnitPublisher publisher(participant, config.topic_prefix, "site", "hp1", 1s);
  Subscriber subscriber(participant, config.topic_prefix);
  const std::int64_t t = test::now_ns();

  for (const double bad : {kNaN, kInf, -kInf}) {
    VirtualSensorSample vs = good_vs(t);
    vs.value = bad;
    CHECK(publisher.publish(vs) == PublishStatus::kNonFinite);
    vs = good_vs(t);
    vs.sigma = bad;
    CHECK(publisher.publish(vs) == PublishStatus::kNonFinite);

    ObservationSample obs;
    obs.point = "supply_air_temperature";
    obs.timestamp_ns = t;
    for (double ObservationSample::*field :
         {&ObservationSample::value, &ObservationSample::predicted, &ObservationSample::innovation,
          &ObservationSample::innovation_variance, &ObservationSample::test_ratio}) {
      ObservationSample o = obs;
      o.*field = bad;
      CHECK(publisher.publish(o) == PublishStatus::kNonFinite);
    }

    HealthSample health;
    health.timestamp_ns = t;
    health.cycle_time_ms = bad;
    CHECK(publisher.publish(health) == PublishStatus::kNonFinite);
    health.cycle_time_ms = 1.0;
    health.cycle_time_max_ms = bad;
    CHECK(publisher.publish(health) == PublishStatus::kNonFinite);
  }
  PublisherStats stats = publisher.stats();
  CHECK(stats.rejected_non_finite == 3 * (2 + 5 + 2));
  CHECK(stats.rejected_invalid == 0);
  CHECK(stats.published == 0);

  // Negative uncertainties and timestamps are invalid too.
  VirtualSensorSample vs = good_vs(t);
  vs.sigma = -0.1;
  CHECK(publisher.publish(vs) == PublishStatus::kInvalidValue);
  vs = good_vs(-1);
  CHECK(publisher.publish(vs) == PublishStatus::kInvalidTimestamp);
  ObservationSample obs;
  obs.point = "p";
  obs.innovation_variance = -1.0;
  CHECK(publisher.publish(obs) == PublishStatus::kInvalidValue);
  CHECK(publisher.stats().rejected_invalid == 3);

  // Nothing refused reached the wire: the first sample a reader sees is the good one.
  REQUIRE(publisher.publish(good_vs(t)) == PublishStatus::kOk);
  std::vector<Record> records;
  REQUIRE(test::collect(subscriber, records, 1));
  REQUIRE(records.size() == 1);
  const auto& received = std::get<VirtualSensorRecord>(records[0]);
  CHECK(received.value == 21.43);
  CHECK(std::isfinite(received.sigma));
  // ...and nothing more arrives.
  CHECK(subscriber.wait_and_take(300ms, records) == 0);
}

TEST_CASE("names that do not fit are refused and never truncated", "[dds][guards]") {
  const auto config = test::loopback_config(kDomainNames);
  Participant participant(config);
  UnitPublisher publisher(participant, config.topic_prefix, "site", "hp1", 1s);
  const std::int64_t t = test::now_ns();

  const std::string longest(kMaxNameLength, 'n');
  const std::string too_long(kMaxNameLength + 1, 'n');
  VirtualSensorSample vs = good_vs(t);
  vs.name = too_long;
  CHECK(publisher.publish(vs) == PublishStatus::kInvalidName);
  vs.name = "";
  CHECK(publisher.publish(vs) == PublishStatus::kInvalidName);
  vs.name = std::string_view("ab\0cd", 5);
  CHECK(publisher.publish(vs) == PublishStatus::kInvalidName);
  vs.name = longest;
  CHECK(publisher.publish(vs) == PublishStatus::kOk);

  const std::string unit_too_long(kMaxEngUnitLength + 1, 'u');
  vs.eng_unit = unit_too_long;
  CHECK(publisher.publish(vs) == PublishStatus::kInvalidUnit);
  vs.eng_unit = "";
  CHECK(publisher.publish(vs) == PublishStatus::kOk);  // dimensionless

  ObservationSample obs;
  obs.point = too_long;
  CHECK(publisher.publish(obs) == PublishStatus::kInvalidName);
  obs.point = longest;
  CHECK(publisher.publish(obs) == PublishStatus::kOk);

  const PublisherStats stats = publisher.stats();
  CHECK(stats.rejected_invalid == 5);
  CHECK(stats.published == 3);
  CHECK(stats.dds_errors == 0);
}

TEST_CASE("bad keys or prefix or period are refused at creation", "[dds][guards]") {
  const auto config = test::loopback_config(kDomainCreation);
  Participant participant(config);
  const std::string too_long(kMaxNameLength + 1, 'x');
  CHECK_THROWS_AS(UnitPublisher(participant, config.topic_prefix, too_long, "hp1", 1s),
                  std::invalid_argument);
  CHECK_THROWS_AS(UnitPublisher(participant, config.topic_prefix, "site", too_long, 1s),
                  std::invalid_argument);
  CHECK_THROWS_AS(UnitPublisher(participant, config.topic_prefix, "site", "", 1s),
                  std::invalid_argument);
  CHECK_THROWS_AS(UnitPublisher(participant, "bad/prefix", "site", "hp1", 1s),
                  std::invalid_argument);
  CHECK_THROWS_AS(UnitPublisher(participant, config.topic_prefix, "site", "hp1", 0s),
                  std::invalid_argument);
  CHECK_THROWS_AS(Subscriber(participant, "bad prefix"), std::invalid_argument);
  CHECK_NOTHROW(
      UnitPublisher(participant, config.topic_prefix, std::string(kMaxNameLength, 's'), "hp1", 1s));
}
