// Subscriber: readers of the hvac-twin state topics, for tools (hvac-twin-echo), dashboards and
// tests. Samples arrive as owned C++ records; no Cyclone type is visible.
//
// QoS: the state QoS (io/dds/qos.hpp) with the given period, or, for period 0, a reader that
// requests no deadline and automatic liveliness and so matches any hvac-twin writer. Either way
// a new reader receives the last sample of every key already published (transient-local).
//
// Threads: one thread at a time per Subscriber. Allocation and exceptions: construction throws;
// wait_and_take()/take() allocate the records (this is not a periodic real-time path) and do not
// throw except std::bad_alloc.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include "io/dds/participant.hpp"
#include "io/dds/types.hpp"

namespace hvac_twin::dds {

struct VirtualSensorRecord {
  std::string site, unit, name;
  double value = 0.0;
  double sigma = 0.0;
  std::string eng_unit;
  EstimateQuality quality = EstimateQuality::kNotReady;
  std::uint32_t flags = 0;
  std::uint64_t fused_points = 0;
  std::int64_t timestamp_ns = 0;
  std::uint64_t cycle = 0;
  std::int64_t source_timestamp_ns = 0;  // DDS source timestamp (equals timestamp_ns)
};

struct ObservationRecord {
  std::string site, unit, point;
  double value = 0.0;
  PointQuality quality = PointQuality::kNotYetRead;
  std::uint8_t exception_code = 0;
  double predicted = 0.0;
  double innovation = 0.0;
  double innovation_variance = 0.0;
  double test_ratio = 0.0;
  bool fused = false;
  std::int64_t timestamp_ns = 0;
  std::uint64_t cycle = 0;
  std::int64_t source_timestamp_ns = 0;
};

struct HealthRecord {
  std::string site, unit;
  std::uint64_t cycle = 0;
  double cycle_time_ms = 0.0;
  double cycle_time_max_ms = 0.0;
  std::uint64_t overruns = 0;
  std::uint64_t degraded_cycles = 0;
  std::uint64_t gate_rejections = 0;
  std::uint64_t numerical_resets = 0;
  std::uint64_t publish_rejections = 0;
  EstimateQuality quality = EstimateQuality::kNotReady;
  bool modbus_connected = false;
  std::uint64_t modbus_polls_ok = 0;
  std::uint64_t modbus_polls_exception = 0;
  std::uint64_t modbus_polls_failed = 0;
  std::uint64_t modbus_reconnects = 0;
  std::string modbus_last_error;
  std::int64_t timestamp_ns = 0;
  std::int64_t source_timestamp_ns = 0;
};

struct LeakDiagnosticRecord : LeakDiagnosticSample {
  std::string site, unit;
  std::int64_t source_timestamp_ns = 0;
};

struct ConsistencyRecord {
  std::string site, unit, point;  // point: a measured point's name, or kAllPoints
  std::uint32_t window_cycles = 0;
  std::uint32_t samples = 0;
  double mean_nis = 0.0;
  double band_low = 0.0;
  double band_high = 0.0;
  ConsistencyVerdict verdict = ConsistencyVerdict::kInsufficientData;
  double rejected_share = 0.0;
  std::int64_t timestamp_ns = 0;
  std::uint64_t cycle = 0;
  std::int64_t source_timestamp_ns = 0;
};

struct UnitEstimateRecord {
  struct Entry {
    std::string name;
    double value = 0.0;
    double sigma = 0.0;
    std::string eng_unit;
  };
  std::string site, unit;
  std::vector<Entry> estimates;  // the valid entries (estimate_count, at most kMaxUnitEstimates)
  EstimateQuality quality = EstimateQuality::kNotReady;
  std::uint32_t flags = 0;
  std::uint64_t fused_points = 0;
  std::int64_t timestamp_ns = 0;
  std::uint64_t cycle = 0;
  std::int64_t source_timestamp_ns = 0;
};

using Record = std::variant<VirtualSensorRecord, ObservationRecord, HealthRecord,
                            LeakDiagnosticRecord, ConsistencyRecord, UnitEstimateRecord>;

// Which topics to read.
struct TopicSet {
  bool virtual_sensor = true;
  bool observation = true;
  bool estimator_health = true;
  bool leak_diagnostic = true;
  bool estimator_consistency = true;
  bool unit_estimate = true;
  bool contains(Topic topic) const noexcept;
};

// An instance that lost its writers without a sample: their liveliness lapsed (a killed or hung
// publisher), they were deleted, or the instance was disposed. Cyclone delivers it as a sample
// without data; only its key is known, and every topic's key starts with site and unit.
struct InstanceLost {
  Topic topic = Topic::kVirtualSensor;
  std::string site, unit;
  // false: no live writer (NOT_ALIVE_NO_WRITERS); true: disposed. Cyclone disposes the instances
  // of an auto-disposing writer (the default, and the daemon's) when its liveliness lapses, so a
  // killed publisher may show as either.
  bool disposed = false;
};

// Communication status of one reader (cumulative counts since creation).
struct ReaderStatus {
  std::uint32_t matched_writers = 0;   // writers currently matched
  std::uint32_t alive_writers = 0;     // matched writers whose liveliness is asserted
  std::uint32_t deadline_missed = 0;   // requested-deadline misses (period > 0 only)
  std::uint32_t incompatible_qos = 0;  // writers refused for incompatible QoS
};

class Subscriber {
 public:
  // period: the publisher's wall-clock cycle period, or 0 to accept any writer (see above).
  // Throws std::invalid_argument for a bad prefix or period, std::runtime_error naming the topic
  // if Cyclone refuses a topic, reader or the waitset.
  Subscriber(Participant& participant, std::string_view topic_prefix, TopicSet topics = {},
             std::chrono::nanoseconds period = std::chrono::nanoseconds::zero());
  ~Subscriber();
  Subscriber(const Subscriber&) = delete;
  Subscriber& operator=(const Subscriber&) = delete;
  Subscriber(Subscriber&&) = delete;
  Subscriber& operator=(Subscriber&&) = delete;

  // Waits up to `timeout` for data on any subscribed topic, then takes everything available
  // and appends it to `out` (samples with valid data only). Returns how many were appended;
  // 0 on timeout. Returns -1 if Cyclone reports an error (Cyclone's code in last_error()).
  // With `lost`, instances that lost their writers (or were disposed) are appended there;
  // without, those notifications are taken and dropped.
  std::ptrdiff_t wait_and_take(std::chrono::nanoseconds timeout, std::vector<Record>& out,
                               std::vector<InstanceLost>* lost = nullptr);
  // Takes everything available without waiting; same results as wait_and_take.
  std::ptrdiff_t take(std::vector<Record>& out, std::vector<InstanceLost>* lost = nullptr);

  // Status of the reader of `topic` (zeros if that topic is not subscribed). Throws
  // std::runtime_error if Cyclone cannot report it.
  ReaderStatus status(Topic topic) const;
  std::int32_t last_error() const noexcept { return last_error_; }

 private:
  struct Readers;  // Cyclone entities
  std::unique_ptr<Readers> readers_;
  std::int32_t last_error_ = 0;
};

}  // namespace hvac_twin::dds
