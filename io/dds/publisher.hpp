// UnitPublisher: the DDS writers of one (site, unit). Creates the six state topics
// "<topic_prefix>/virtual_sensor", "<topic_prefix>/observation",
// "<topic_prefix>/estimator_health", "<topic_prefix>/leak_diagnostic",
// "<topic_prefix>/estimator_consistency" and "<topic_prefix>/unit_estimate" with the state QoS
// (io/dds/qos.hpp) and one writer each.
//
// Liveliness is MANUAL_BY_TOPIC: a writer is alive while it writes. The unit's cycle publishes
// its virtual sensors (one sample each, and all of them in one unit_estimate), observations,
// consistency and health after every completed cycle; a topic
// with nothing to write in a cycle is kept alive with assert_liveliness(). A hung or killed cycle
// then shows as missed deadlines (2.5 x period) and lost liveliness (3 x period) at every reader.
// Checked with Cyclone DDS 0.10.2 (local and remote readers): assert_liveliness() extends the
// lease of a writer that is alive, but once its liveliness was lost only a write revives it.
// The deadline counts per instance, so a key that is alive but not updated still misses it.
//
// Threads: construct and destroy at start-up/shut-down; call publish()/assert_liveliness() from
// one thread at a time (the unit's cycle thread). stats() may be read from any thread.
// Allocation and exceptions: only the constructor allocates or throws. publish() copies the
// sample into a pre-built wire struct and returns a status; it never allocates in our code
// (Cyclone's dds_write serialises into its own pooled buffers) and blocks at most
// kMaxBlockingTime (10 ms) if the reliable history is full of unacknowledged samples.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <string_view>

#include "io/dds/participant.hpp"
#include "io/dds/types.hpp"
#include "io/dds/unit_sink.hpp"

namespace hvac_twin::dds {

class UnitPublisher final : public UnitSink {
 public:
  // site, unit: keys of every sample, 1..kMaxNameLength bytes. period: the unit's wall-clock
  // cycle period (EstimatorConfig::period_s / RuntimeConfig::time_scale), > 0.
  // Throws std::invalid_argument for a bad site, unit, prefix or period, std::runtime_error
  // naming the topic if Cyclone refuses a topic or writer.
  // leak_diagnostic: also create the leak_diagnostic writer (units whose model estimates a leak
  // rate); without it publish(LeakDiagnosticSample) returns kDdsError and nothing is written.
  UnitPublisher(Participant& participant, std::string_view topic_prefix, std::string_view site,
                std::string_view unit, std::chrono::nanoseconds period,
                bool leak_diagnostic = true);
  ~UnitPublisher() override;
  UnitPublisher(const UnitPublisher&) = delete;
  UnitPublisher& operator=(const UnitPublisher&) = delete;
  UnitPublisher(UnitPublisher&&) = delete;
  UnitPublisher& operator=(UnitPublisher&&) = delete;

  // Writes one sample with the sample's timestamp as DDS source timestamp. Cycle thread only.
  PublishStatus publish(const VirtualSensorSample& sample) noexcept override;
  PublishStatus publish(const ObservationSample& sample) noexcept override;
  // Also fills the wire field publish_rejections from stats().rejected().
  PublishStatus publish(const HealthSample& sample) noexcept override;
  PublishStatus publish(const LeakDiagnosticSample& sample) noexcept override;
  PublishStatus publish(const ConsistencySample& sample) noexcept override;
  // Refused whole if any entry is invalid (the entry's status) or there are more than
  // kMaxUnitEstimates; a refused sample counts once.
  PublishStatus publish(const UnitEstimateSample& sample) noexcept override;
  // Asserts liveliness of all its writers without writing (a cycle with nothing to publish on
  // a topic). Does not revive a writer whose liveliness was already lost: write a sample for
  // that. Returns kDdsError if Cyclone refuses. Cycle thread only.
  PublishStatus assert_liveliness() noexcept override;

  PublisherStats stats() const noexcept override;  // any thread

 private:
  struct Wire;  // pre-filled wire samples and writer handles (Cyclone types)
  PublishStatus write(std::int32_t writer, const void* sample, std::int64_t timestamp_ns) noexcept;
  PublishStatus reject(PublishStatus status) noexcept;

  std::unique_ptr<Wire> wire_;
  std::atomic<std::uint64_t> published_{0};
  std::atomic<std::uint64_t> rejected_non_finite_{0};
  std::atomic<std::uint64_t> rejected_invalid_{0};
  std::atomic<std::uint64_t> dds_errors_{0};
  std::atomic<std::int32_t> last_dds_error_{0};
};

}  // namespace hvac_twin::dds
