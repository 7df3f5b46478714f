// THE QoS of every hvac-twin topic, writer and reader, composed in one function.
//
// Internal to io/dds: this header includes the Cyclone C API, so only io/dds sources and their
// tests include it; the rest of the daemon never does.
//
// State semantics (reliability.md): RELIABLE, TRANSIENT_LOCAL, KEEP_LAST 1 per instance (a late
// joiner gets the last sample of every key at once), DEADLINE 2.5 x period (a hung cycle is
// noticed), LIVELINESS MANUAL_BY_TOPIC with a lease of 3 x period: a writer is alive only while
// it writes, and the daemon writes (or calls UnitPublisher::assert_liveliness) after every
// completed cycle, so a killed or hung publisher is noticed within the lease.
//
// Threads: any. Allocation: make_state_qos allocates the dds_qos_t (creation time only).
#pragma once

#include <dds/dds.h>

#include <chrono>
#include <memory>

namespace hvac_twin::dds {

struct QosDeleter {
  void operator()(dds_qos_t* qos) const noexcept { dds_delete_qos(qos); }
};
using QosPtr = std::unique_ptr<dds_qos_t, QosDeleter>;

// For readers that do not know the publisher's period (the echo tool, dashboards): request no
// deadline and AUTOMATIC liveliness with an infinite lease, which every state writer satisfies.
inline constexpr std::chrono::nanoseconds kAnyPeriod{0};
// Longest period accepted (longer ones are certainly a unit mistake) [wall].
inline constexpr std::chrono::nanoseconds kMaxPeriod = std::chrono::hours(24);
// Longest time a reliable write may block the cycle thread when the writer's history is full of
// unacknowledged samples; after it the write fails with a timeout instead [wall].
inline constexpr std::chrono::nanoseconds kMaxBlockingTime = std::chrono::milliseconds(10);

// Offered (writer) and requested (reader) deadline per instance for a cycle period [wall].
constexpr std::chrono::nanoseconds state_deadline(std::chrono::nanoseconds period) {
  return period * 5 / 2;
}
// MANUAL_BY_TOPIC liveliness lease for a cycle period [wall].
constexpr std::chrono::nanoseconds state_liveliness_lease(std::chrono::nanoseconds period) {
  return period * 3;
}

// The QoS for topics, writers and readers of the state topics. `period` is the wall-clock cycle
// period of the publishing unit (EstimatorConfig::period_s / RuntimeConfig::time_scale), or
// kAnyPeriod for a reader that accepts any writer. Topics are always created with
// make_state_qos(kAnyPeriod): Cyclone refuses a second creation of a topic in a participant with
// a different QoS ("Inconsistent Policy"), so the topic QoS must not depend on a unit's period;
// writers and readers carry their own. Throws std::invalid_argument if period is
// negative or above kMaxPeriod, std::bad_alloc if Cyclone cannot allocate the QoS.
QosPtr make_state_qos(std::chrono::nanoseconds period);

}  // namespace hvac_twin::dds
