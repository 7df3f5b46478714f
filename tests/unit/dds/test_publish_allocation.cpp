// The publish path allocates nothing in our code: operator new is counted around publish().
// (Cyclone's own buffers come from malloc and its serdata pool, outside this count.)
#include <catch2/catch.hpp>
#include <string>
#include <vector>

#include "dds_test_support.hpp"
#include "io/dds/publisher.hpp"
#include "tests/support/alloc_counter.hpp"

namespace {
constexpr int kDomainAllocation = 116;
}  // namespace

using namespace hvac_twin::dds;
using namespace std::chrono_literals;

TEST_CASE("publish allocates nothing", "[dds][allocation]") {
  const auto config = test::loopback_config(kDomainAllocation);
  Participant participant(config);
  UnitPublisher publisher(participant, config.topic_prefix, "site", "hp1", 1s);
  const hvac_twin::test::AllocationScope probe;
  const std::string too_long(kMaxNameLength + 1, 'x');
  const std::string long_error(300, 'e');
  REQUIRE(probe.count() > 0);  // the counter sees allocations

  VirtualSensorSample vs;
  vs.name = "condenser_pressure";
  vs.eng_unit = "Pa";
  ObservationSample obs;
  obs.point = "supply_air_temperature";
  HealthSample health;
  health.modbus_last_error = long_error;
  ConsistencySample consistency;
  consistency.point = "supply_air_temperature";
  consistency.mean_nis = 1.02;
  VirtualSensorSample bad = vs;
  bad.name = too_long;
  const std::vector<EstimateEntry> entries(
      24,
      EstimateEntry{.name = "condenser_pressure", .value = 2.5e6, .sigma = 1e3, .eng_unit = "Pa"});
  UnitEstimateSample all_outputs{.estimates = entries};

  const auto publish_all = [&](std::uint64_t cycle) {
    vs.cycle = obs.cycle = health.cycle = consistency.cycle = all_outputs.cycle = cycle;
    vs.timestamp_ns = obs.timestamp_ns = health.timestamp_ns = consistency.timestamp_ns =
        all_outputs.timestamp_ns = test::now_ns();
    vs.value = static_cast<double>(cycle);
    bool ok = publisher.publish(vs) == PublishStatus::kOk;
    ok = ok && publisher.publish(obs) == PublishStatus::kOk;
    ok = ok && publisher.publish(health) == PublishStatus::kOk;
    ok = ok && publisher.publish(consistency) == PublishStatus::kOk;
    ok = ok && publisher.publish(all_outputs) == PublishStatus::kOk;
    ok = ok && publisher.publish(bad) == PublishStatus::kInvalidName;
    ok = ok && publisher.assert_liveliness() == PublishStatus::kOk;
    return ok;
  };
  REQUIRE(publish_all(0));  // warm-up: Cyclone sets up instances on first write

  const hvac_twin::test::AllocationScope scope;
  bool all_ok = true;
  for (std::uint64_t cycle = 1; cycle <= 200; ++cycle)
    all_ok = publish_all(cycle) && all_ok;
  CHECK(all_ok);
  CHECK(scope.count() == 0);
}
