// What a unit's cycle publishes, as an interface: the DDS UnitPublisher on a live unit, a CSV
// writer in hvac-twin-replay. The pipeline writes through this interface only, so a replay
// produces the very samples the daemon publishes.
#pragma once

#include <cstdint>
#include <string_view>

#include "io/dds/types.hpp"

namespace hvac_twin::dds {

enum class PublishStatus : std::uint8_t {
  kOk = 0,
  kNonFinite,         // a double was NaN or infinite: not published (design: NaN never published)
  kInvalidValue,      // sigma, innovation_variance, test_ratio or a cycle time was negative
                      // (or a consistency figure negative, its rejected_share above 1)
  kInvalidName,       // name/point empty, longer than kMaxNameLength or containing NUL
  kInvalidUnit,       // eng_unit longer than kMaxEngUnitLength or containing NUL
  kInvalidTimestamp,  // timestamp_ns negative
  kDdsError,          // Cyclone refused the write (see PublisherStats::last_dds_error)
};
std::string_view to_string(PublishStatus status) noexcept;

// Counters since construction. Every refused sample counts once in exactly one counter.
struct PublisherStats {
  std::uint64_t published = 0;
  std::uint64_t rejected_non_finite = 0;
  std::uint64_t rejected_invalid =
      0;  // kInvalidValue, kInvalidName, kInvalidUnit, kInvalidTimestamp
  std::uint64_t dds_errors = 0;
  std::int32_t last_dds_error = 0;  // last Cyclone return code (< 0), 0 if none
  std::uint64_t rejected() const noexcept { return rejected_non_finite + rejected_invalid; }
};

// One sample per call, from the unit's cycle thread; stats() from any thread. Implementations
// never allocate or throw in publish().
class UnitSink {
 public:
  virtual ~UnitSink() = default;
  virtual PublishStatus publish(const VirtualSensorSample& sample) noexcept = 0;
  virtual PublishStatus publish(const ObservationSample& sample) noexcept = 0;
  virtual PublishStatus publish(const HealthSample& sample) noexcept = 0;  // last of a cycle
  virtual PublishStatus publish(const LeakDiagnosticSample& sample) noexcept = 0;
  virtual PublishStatus publish(const ConsistencySample& sample) noexcept = 0;
  virtual PublishStatus publish(const UnitEstimateSample& sample) noexcept = 0;
  // A cycle with nothing to write on some topic.
  virtual PublishStatus assert_liveliness() noexcept = 0;
  [[nodiscard]] virtual PublisherStats stats() const noexcept = 0;
};

}  // namespace hvac_twin::dds
