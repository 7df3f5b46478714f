// unit_estimate (issue 17, item 12): every virtual sensor of a unit from one cycle in one sample,
// for readers that want a cycle's outputs together or hold few instances. Through a real
// Cyclone writer and reader: every entry bit-exact, the count honoured, the guard whole-sample.
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "dds_test_support.hpp"
#include "io/dds/publisher.hpp"
#include "io/dds/subscriber.hpp"

using namespace hvac_twin::dds;
using namespace std::chrono_literals;

namespace {
constexpr int kDomainUnitEstimate = 121;
}  // namespace

TEST_CASE("a unit's estimates of one cycle round-trip in one sample, and it is guarded whole",
          "[dds][roundtrip]") {
  const auto config = test::loopback_config(kDomainUnitEstimate);
  Participant writer_side(config);
  Participant reader_side(config);
  UnitPublisher publisher(writer_side, config.topic_prefix, "site", "hp-1", 1s);
  Subscriber subscriber(reader_side, config.topic_prefix,
                        TopicSet{false, false, false, false, false, true}, 1s);

  // As many entries as a heat pump has outputs; the longest name and unit the wire takes.
  std::vector<std::string> names;
  for (int i = 0; i < 24; ++i)
    names.push_back("output_" + std::to_string(i));
  names[0] = std::string(kMaxNameLength, 'n');
  const std::string longest_unit(kMaxEngUnitLength, 'u');
  std::vector<EstimateEntry> entries;
  for (std::size_t i = 0; i < names.size(); ++i)
    entries.push_back({.name = names[i],
                       .value = std::ldexp(1.0 + 1e-15 * static_cast<double>(i), 40 - int(i)),
                       .sigma = 1.0 / (3.0 + static_cast<double>(i)),
                       .eng_unit = i == 1 ? std::string_view(longest_unit) : "kW"});
  entries[2].value = -std::numeric_limits<double>::denorm_min();
  entries[3].sigma = 0.0;
  const std::int64_t t0 = test::now_ns();
  UnitEstimateSample sample{.estimates = entries,
                            .quality = EstimateQuality::kDegraded,
                            .flags = kFlagConstraintActive | kFlagDeadlineOverrun,
                            .fused_points = 0x5Bu,
                            .timestamp_ns = t0,
                            .cycle = 0xFFFF'FFFF'FFFF'FFF1ull};
  REQUIRE(publisher.publish(sample) == PublishStatus::kOk);

  std::vector<Record> records;
  REQUIRE(test::collect(subscriber, records, 1));
  auto got = test::only<UnitEstimateRecord>(records);
  REQUIRE(got.size() == 1);
  const UnitEstimateRecord& r = got[0];
  CHECK(r.site == "site");
  CHECK(r.unit == "hp-1");
  CHECK(r.quality == EstimateQuality::kDegraded);
  CHECK(r.flags == sample.flags);
  CHECK(r.fused_points == 0x5Bu);
  CHECK(r.timestamp_ns == t0);
  CHECK(r.source_timestamp_ns == t0);
  CHECK(r.cycle == sample.cycle);
  REQUIRE(r.estimates.size() == entries.size());
  for (std::size_t i = 0; i < entries.size(); ++i) {
    INFO("entry " << i);
    CHECK(r.estimates[i].name == entries[i].name);
    CHECK(r.estimates[i].value == entries[i].value);  // bit-exact
    CHECK(std::signbit(r.estimates[i].value) == std::signbit(entries[i].value));
    CHECK(r.estimates[i].sigma == entries[i].sigma);
    CHECK(r.estimates[i].eng_unit == entries[i].eng_unit);
  }

  // Fewer entries next cycle: the reader sees exactly those (keep-last 1, one instance per
  // unit); the full 64 pass, 65 do not.
  sample.estimates = std::span(entries).first(3);
  sample.cycle += 1;
  REQUIRE(publisher.publish(sample) == PublishStatus::kOk);
  records.clear();
  REQUIRE(test::collect(subscriber, records, 1));
  got = test::only<UnitEstimateRecord>(records);
  REQUIRE(got.size() == 1);
  CHECK(got[0].estimates.size() == 3);
  CHECK(got[0].estimates[2].value == entries[2].value);
  std::vector<EstimateEntry> many(kMaxUnitEstimates + 1, EstimateEntry{.name = "x", .sigma = 1.0});
  sample.estimates = std::span(many).first(kMaxUnitEstimates);
  CHECK(publisher.publish(sample) == PublishStatus::kOk);
  records.clear();
  REQUIRE(test::collect(subscriber, records, 1));
  got = test::only<UnitEstimateRecord>(records);
  REQUIRE(got.size() == 1);
  CHECK(got[0].estimates.size() == kMaxUnitEstimates);

  // The guard refuses the whole sample, for any one bad entry, and counts it once.
  const auto rejected_before = publisher.stats().rejected();
  const auto with = [&](std::size_t i, auto change) {
    std::vector<EstimateEntry> bad = entries;
    change(bad[i]);
    UnitEstimateSample s = sample;
    s.estimates = bad;
    return publisher.publish(s);
  };
  sample.estimates = many;
  CHECK(publisher.publish(sample) == PublishStatus::kInvalidValue);
  sample.estimates = entries;
  CHECK(with(23, [](EstimateEntry& e) { e.value = std::nan(""); }) == PublishStatus::kNonFinite);
  CHECK(with(5, [](EstimateEntry& e) { e.sigma = std::numeric_limits<double>::infinity(); }) ==
        PublishStatus::kNonFinite);
  CHECK(with(5, [](EstimateEntry& e) { e.sigma = -1e-9; }) == PublishStatus::kInvalidValue);
  CHECK(with(7, [](EstimateEntry& e) { e.name = ""; }) == PublishStatus::kInvalidName);
  const std::string too_long(kMaxEngUnitLength + 1, 'u');
  CHECK(with(7, [&](EstimateEntry& e) { e.eng_unit = too_long; }) == PublishStatus::kInvalidUnit);
  sample.timestamp_ns = -1;
  CHECK(publisher.publish(sample) == PublishStatus::kInvalidTimestamp);
  CHECK(publisher.stats().rejected() == rejected_before + 7);
  records.clear();
  CHECK(subscriber.wait_and_take(300ms, records) == 0);  // none of them reached the wire
}
