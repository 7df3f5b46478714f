#include "io/dds/subscriber.hpp"

#include <dds/dds.h>

#include <algorithm>
#include <iterator>
#include <stdexcept>
#include <string>

#include "io/dds/detail/entity.hpp"
#include "io/dds/detail/wire.hpp"
#include "io/dds/qos.hpp"

namespace hvac_twin::dds {

bool TopicSet::contains(Topic topic) const noexcept {
  switch (topic) {
    case Topic::kVirtualSensor:
      return virtual_sensor;
    case Topic::kObservation:
      return observation;
    case Topic::kEstimatorHealth:
      return estimator_health;
    case Topic::kLeakDiagnostic:
      return leak_diagnostic;
    case Topic::kEstimatorConsistency:
      return estimator_consistency;
    case Topic::kUnitEstimate:
      return unit_estimate;
  }
  return false;
}

struct Subscriber::Readers {
  detail::Entity topics[kNumTopics];  // indexed by Topic; empty if not subscribed
  detail::Entity readers[kNumTopics];
  detail::Entity waitset;  // declared last: detached and deleted first
};

namespace {

// The fields VirtualSensor and UnitEstimate share: one cycle's quality and provenance.
template <class Record, class Wire>
void convert_cycle(const Wire& w, dds_time_t source_ts, Record& r) {
  r.quality = detail::from_wire(w.quality);
  r.flags = w.flags;
  r.fused_points = w.fused_points;
  r.timestamp_ns = w.timestamp_ns;
  r.cycle = w.cycle;
  r.source_timestamp_ns = source_ts;
}

VirtualSensorRecord convert(const hvac_twin_VirtualSensor& w, dds_time_t source_ts) {
  VirtualSensorRecord r;
  r.site = detail::view_bounded(w.site);
  r.unit = detail::view_bounded(w.unit);
  r.name = detail::view_bounded(w.name);
  r.value = w.value;
  r.sigma = w.sigma;
  r.eng_unit = detail::view_bounded(w.eng_unit);
  convert_cycle(w, source_ts, r);
  return r;
}

ObservationRecord convert(const hvac_twin_Observation& w, dds_time_t source_ts) {
  ObservationRecord r;
  r.site = detail::view_bounded(w.site);
  r.unit = detail::view_bounded(w.unit);
  r.point = detail::view_bounded(w.point);
  r.value = w.value;
  r.quality = detail::from_wire(w.quality);
  r.exception_code = w.exception_code;
  r.predicted = w.predicted;
  r.innovation = w.innovation;
  r.innovation_variance = w.innovation_variance;
  r.test_ratio = w.test_ratio;
  r.fused = w.fused;
  r.timestamp_ns = w.timestamp_ns;
  r.cycle = w.cycle;
  r.source_timestamp_ns = source_ts;
  return r;
}

HealthRecord convert(const hvac_twin_EstimatorHealth& w, dds_time_t source_ts) {
  HealthRecord r;
  r.site = detail::view_bounded(w.site);
  r.unit = detail::view_bounded(w.unit);
  r.cycle = w.cycle;
  r.cycle_time_ms = w.cycle_time_ms;
  r.cycle_time_max_ms = w.cycle_time_max_ms;
  r.overruns = w.overruns;
  r.degraded_cycles = w.degraded_cycles;
  r.gate_rejections = w.gate_rejections;
  r.numerical_resets = w.numerical_resets;
  r.publish_rejections = w.publish_rejections;
  r.quality = detail::from_wire(w.quality);
  r.modbus_connected = w.modbus_connected;
  r.modbus_polls_ok = w.modbus_polls_ok;
  r.modbus_polls_exception = w.modbus_polls_exception;
  r.modbus_polls_failed = w.modbus_polls_failed;
  r.modbus_reconnects = w.modbus_reconnects;
  r.modbus_last_error = detail::view_bounded(w.modbus_last_error);
  r.timestamp_ns = w.timestamp_ns;
  r.source_timestamp_ns = source_ts;
  return r;
}

LeakDiagnosticRecord convert(const hvac_twin_LeakDiagnostic& w, dds_time_t source_ts) {
  LeakDiagnosticRecord r;
  r.site = detail::view_bounded(w.site);
  r.unit = detail::view_bounded(w.unit);
  r.state = detail::from_wire(w.state);
  r.hold = detail::from_wire(w.hold);
  r.charge = w.charge;
  r.charge_sigma = w.charge_sigma;
  r.nameplate_charge = w.nameplate_charge;
  r.leak_rate = w.leak_rate;
  r.leak_rate_sigma = w.leak_rate_sigma;
  r.cusum = w.cusum;
  r.rate_cusum = w.rate_cusum;
  r.charge_cusum = w.charge_cusum;
  r.charge_reference = w.charge_reference;
  r.threshold = w.threshold;
  r.false_alarm_interval_days = w.false_alarm_interval_days;
  r.decisions = w.decisions;
  r.suspect_since_ns = w.suspect_since_ns;
  r.leak_since_ns = w.leak_since_ns;
  r.quality = detail::from_wire(w.quality);
  r.timestamp_ns = w.timestamp_ns;
  r.cycle = w.cycle;
  r.source_timestamp_ns = source_ts;
  return r;
}

ConsistencyRecord convert(const hvac_twin_EstimatorConsistency& w, dds_time_t source_ts) {
  ConsistencyRecord r;
  r.site = detail::view_bounded(w.site);
  r.unit = detail::view_bounded(w.unit);
  r.point = detail::view_bounded(w.point);
  r.window_cycles = w.window_cycles;
  r.samples = w.samples;
  r.mean_nis = w.mean_nis;
  r.band_low = w.band_low;
  r.band_high = w.band_high;
  r.verdict = detail::from_wire(w.verdict);
  r.rejected_share = w.rejected_share;
  r.timestamp_ns = w.timestamp_ns;
  r.cycle = w.cycle;
  r.source_timestamp_ns = source_ts;
  return r;
}

UnitEstimateRecord convert(const hvac_twin_UnitEstimate& w, dds_time_t source_ts) {
  UnitEstimateRecord r;
  r.site = detail::view_bounded(w.site);
  r.unit = detail::view_bounded(w.unit);
  const std::size_t count = std::min<std::size_t>(w.estimate_count, std::size(w.estimates));
  r.estimates.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    const hvac_twin_Estimate& e = w.estimates[i];
    r.estimates.push_back({std::string(detail::view_bounded(e.name)), e.value, e.sigma,
                           std::string(detail::view_bounded(e.eng_unit))});
  }
  convert_cycle(w, source_ts, r);
  return r;
}

// Takes every available sample of one reader into `out`. The wire types hold only bounded
// (inline) strings, so Cyclone deserialises straight into the caller-provided array.
// Invalid samples carry the instance's key: its site and unit come first in every topic's key.
template <typename Wire>
std::ptrdiff_t take_all(dds_entity_t reader, Topic topic, std::vector<Record>& out,
                        std::vector<InstanceLost>* lost, std::int32_t& error) {
  constexpr std::size_t kBatch = 16;
  Wire samples[kBatch]{};
  void* buffers[kBatch];
  dds_sample_info_t infos[kBatch];
  std::ptrdiff_t taken = 0;
  for (;;) {
    for (std::size_t i = 0; i < kBatch; ++i)
      buffers[i] = &samples[i];
    const dds_return_t n = dds_take(reader, buffers, infos, kBatch, kBatch);
    if (n < 0) {
      error = n;
      return -1;
    }
    for (dds_return_t i = 0; i < n; ++i) {
      if (!infos[i].valid_data) {  // dispose / no-writers notifications
        if (lost != nullptr && infos[i].instance_state != DDS_IST_ALIVE)
          lost->push_back({topic, std::string(detail::view_bounded(samples[i].site)),
                           std::string(detail::view_bounded(samples[i].unit)),
                           infos[i].instance_state == DDS_IST_NOT_ALIVE_DISPOSED});
        continue;
      }
      out.emplace_back(convert(samples[i], infos[i].source_timestamp));
      ++taken;
    }
    if (static_cast<std::size_t>(n) < kBatch) return taken;
  }
}

void check_status(dds_return_t rc, const char* what) {
  if (rc != DDS_RETCODE_OK) {
    throw std::runtime_error(std::string("cannot read DDS reader status ") + what + ": " +
                             dds_strretcode(rc));
  }
}

}  // namespace

Subscriber::Subscriber(Participant& participant, std::string_view topic_prefix, TopicSet topics,
                       std::chrono::nanoseconds period)
    : readers_(std::make_unique<Readers>()) {
  const QosPtr topic_qos = make_state_qos(kAnyPeriod);  // see make_state_qos
  const QosPtr reader_qos = make_state_qos(period);
  const dds_entity_t pp = participant.native_handle();
  Readers& r = *readers_;
  r.waitset = detail::Entity(dds_create_waitset(pp), "waitset");
  for (const Topic topic : kAllTopics) {
    if (!topics.contains(topic)) continue;
    const std::string name = topic_name(topic_prefix, topic);
    const int i = static_cast<int>(topic);
    r.topics[i] = detail::Entity(
        dds_create_topic(pp, detail::descriptor(topic), name.c_str(), topic_qos.get(), nullptr),
        "topic " + name);
    r.readers[i] = detail::Entity(
        dds_create_reader(pp, r.topics[i].get(), reader_qos.get(), nullptr), "reader of " + name);
    // The read condition is a child of the reader and goes with it.
    const dds_entity_t condition = dds_create_readcondition(r.readers[i].get(), DDS_ANY_STATE);
    if (condition < 0) {
      throw std::runtime_error("cannot create DDS read condition for " + name + ": " +
                               dds_strretcode(condition));
    }
    const dds_return_t rc = dds_waitset_attach(r.waitset.get(), condition, 0);
    if (rc != DDS_RETCODE_OK) {
      throw std::runtime_error("cannot attach DDS reader of " + name + ": " + dds_strretcode(rc));
    }
  }
}

Subscriber::~Subscriber() = default;

std::ptrdiff_t Subscriber::wait_and_take(std::chrono::nanoseconds timeout, std::vector<Record>& out,
                                         std::vector<InstanceLost>* lost) {
  const dds_return_t rc = dds_waitset_wait(readers_->waitset.get(), nullptr, 0, timeout.count());
  if (rc < 0) {
    last_error_ = rc;
    return -1;
  }
  return rc == 0 ? 0 : take(out, lost);
}

std::ptrdiff_t Subscriber::take(std::vector<Record>& out, std::vector<InstanceLost>* lost) {
  std::ptrdiff_t total = 0;
  for (const Topic topic : kAllTopics) {
    const dds_entity_t reader = readers_->readers[static_cast<int>(topic)].get();
    if (reader == 0) continue;
    std::ptrdiff_t n = 0;
    switch (topic) {
      case Topic::kVirtualSensor:
        n = take_all<hvac_twin_VirtualSensor>(reader, topic, out, lost, last_error_);
        break;
      case Topic::kObservation:
        n = take_all<hvac_twin_Observation>(reader, topic, out, lost, last_error_);
        break;
      case Topic::kEstimatorHealth:
        n = take_all<hvac_twin_EstimatorHealth>(reader, topic, out, lost, last_error_);
        break;
      case Topic::kLeakDiagnostic:
        n = take_all<hvac_twin_LeakDiagnostic>(reader, topic, out, lost, last_error_);
        break;
      case Topic::kEstimatorConsistency:
        n = take_all<hvac_twin_EstimatorConsistency>(reader, topic, out, lost, last_error_);
        break;
      case Topic::kUnitEstimate:
        n = take_all<hvac_twin_UnitEstimate>(reader, topic, out, lost, last_error_);
        break;
    }
    if (n < 0) return -1;
    total += n;
  }
  return total;
}

ReaderStatus Subscriber::status(Topic topic) const {
  ReaderStatus s;
  const dds_entity_t reader = readers_->readers[static_cast<int>(topic)].get();
  if (reader == 0) return s;
  dds_subscription_matched_status_t matched;
  check_status(dds_get_subscription_matched_status(reader, &matched), "subscription matched");
  s.matched_writers = matched.current_count;
  dds_liveliness_changed_status_t liveliness;
  check_status(dds_get_liveliness_changed_status(reader, &liveliness), "liveliness changed");
  s.alive_writers = liveliness.alive_count;
  dds_requested_deadline_missed_status_t deadline;
  check_status(dds_get_requested_deadline_missed_status(reader, &deadline), "deadline missed");
  s.deadline_missed = deadline.total_count;
  dds_requested_incompatible_qos_status_t incompatible;
  check_status(dds_get_requested_incompatible_qos_status(reader, &incompatible),
               "incompatible QoS");
  s.incompatible_qos = incompatible.total_count;
  return s;
}

}  // namespace hvac_twin::dds
