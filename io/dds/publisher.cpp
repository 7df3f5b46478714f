#include "io/dds/publisher.hpp"

#include <dds/dds.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "io/dds/detail/entity.hpp"
#include "io/dds/detail/wire.hpp"
#include "io/dds/qos.hpp"

namespace hvac_twin::dds {

struct UnitPublisher::Wire {
  detail::Entity topics[kNumTopics];   // declared before the writers: destroyed after them
  detail::Entity writers[kNumTopics];  // indexed by Topic
  hvac_twin_VirtualSensor virtual_sensor{};
  hvac_twin_Observation observation{};
  hvac_twin_EstimatorHealth health{};
  hvac_twin_LeakDiagnostic leak{};
  hvac_twin_EstimatorConsistency consistency{};
  hvac_twin_UnitEstimate unit_estimate{};

  dds_entity_t writer(Topic topic) const noexcept { return writers[static_cast<int>(topic)].get(); }
};

namespace {

std::string describe_name(std::string_view what, std::string_view value) {
  return "DDS " + std::string(what) + " '" + std::string(value) + "' must be 1.." +
         std::to_string(kMaxNameLength) + " bytes without NUL";
}

bool finite(double x) noexcept {
  return std::isfinite(x);
}

// The fields VirtualSensor and UnitEstimate share: one cycle's quality and provenance.
template <class Wire, class Sample>
void fill_cycle(const Sample& s, Wire& w) noexcept {
  w.quality = detail::to_wire(s.quality);
  w.flags = s.flags;
  w.fused_points = s.fused_points;
  w.timestamp_ns = s.timestamp_ns;
  w.cycle = s.cycle;
}

}  // namespace

std::string_view to_string(PublishStatus status) noexcept {
  switch (status) {
    case PublishStatus::kOk:
      return "ok";
    case PublishStatus::kNonFinite:
      return "non-finite value refused";
    case PublishStatus::kInvalidValue:
      return "negative uncertainty, duration or figure (or a share above 1) refused";
    case PublishStatus::kInvalidName:
      return "empty, too long or NUL-containing name refused";
    case PublishStatus::kInvalidUnit:
      return "too long or NUL-containing engineering unit refused";
    case PublishStatus::kInvalidTimestamp:
      return "negative timestamp refused";
    case PublishStatus::kDdsError:
      return "DDS write failed";
  }
  return "unknown status";
}

UnitPublisher::UnitPublisher(Participant& participant, std::string_view topic_prefix,
                             std::string_view site, std::string_view unit,
                             std::chrono::nanoseconds period, bool leak_diagnostic)
    : wire_(std::make_unique<Wire>()) {
  if (period <= std::chrono::nanoseconds::zero()) {
    throw std::invalid_argument("DDS publisher: the cycle period must be positive");
  }
  Wire& w = *wire_;
  if (!detail::copy_bounded(w.virtual_sensor.site, site, true)) {
    throw std::invalid_argument(describe_name("site", site));
  }
  if (!detail::copy_bounded(w.virtual_sensor.unit, unit, true)) {
    throw std::invalid_argument(describe_name("unit", unit));
  }
  // The keys are fixed for this publisher: fill them once.
  (void)detail::copy_bounded(w.observation.site, site, true);
  (void)detail::copy_bounded(w.observation.unit, unit, true);
  (void)detail::copy_bounded(w.health.site, site, true);
  (void)detail::copy_bounded(w.health.unit, unit, true);
  (void)detail::copy_bounded(w.leak.site, site, true);
  (void)detail::copy_bounded(w.leak.unit, unit, true);
  (void)detail::copy_bounded(w.consistency.site, site, true);
  (void)detail::copy_bounded(w.consistency.unit, unit, true);
  (void)detail::copy_bounded(w.unit_estimate.site, site, true);
  (void)detail::copy_bounded(w.unit_estimate.unit, unit, true);

  const QosPtr topic_qos = make_state_qos(kAnyPeriod);  // see make_state_qos
  const QosPtr writer_qos = make_state_qos(period);
  for (const Topic topic : kAllTopics) {
    if (topic == Topic::kLeakDiagnostic && !leak_diagnostic) continue;
    const std::string name = topic_name(topic_prefix, topic);
    const int i = static_cast<int>(topic);
    w.topics[i] =
        detail::Entity(dds_create_topic(participant.native_handle(), detail::descriptor(topic),
                                        name.c_str(), topic_qos.get(), nullptr),
                       "topic " + name);
    w.writers[i] = detail::Entity(dds_create_writer(participant.native_handle(), w.topics[i].get(),
                                                    writer_qos.get(), nullptr),
                                  "writer of " + name);
  }
}

UnitPublisher::~UnitPublisher() = default;

PublishStatus UnitPublisher::reject(PublishStatus status) noexcept {
  auto& counter = status == PublishStatus::kNonFinite ? rejected_non_finite_ : rejected_invalid_;
  counter.fetch_add(1, std::memory_order_relaxed);
  return status;
}

PublishStatus UnitPublisher::write(std::int32_t writer, const void* sample,
                                   std::int64_t timestamp_ns) noexcept {
  const dds_return_t rc = dds_write_ts(writer, sample, timestamp_ns);
  if (rc != DDS_RETCODE_OK) {
    dds_errors_.fetch_add(1, std::memory_order_relaxed);
    last_dds_error_.store(rc, std::memory_order_relaxed);
    return PublishStatus::kDdsError;
  }
  published_.fetch_add(1, std::memory_order_relaxed);
  return PublishStatus::kOk;
}

PublishStatus UnitPublisher::publish(const VirtualSensorSample& s) noexcept {
  if (!finite(s.value) || !finite(s.sigma)) return reject(PublishStatus::kNonFinite);
  if (s.sigma < 0.0) return reject(PublishStatus::kInvalidValue);
  if (s.timestamp_ns < 0) return reject(PublishStatus::kInvalidTimestamp);
  hvac_twin_VirtualSensor& w = wire_->virtual_sensor;
  if (!detail::copy_bounded(w.name, s.name, true)) return reject(PublishStatus::kInvalidName);
  if (!detail::copy_bounded(w.eng_unit, s.eng_unit, false)) {
    return reject(PublishStatus::kInvalidUnit);
  }
  w.value = s.value;
  w.sigma = s.sigma;
  fill_cycle(s, w);
  return write(wire_->writer(Topic::kVirtualSensor), &w, s.timestamp_ns);
}

PublishStatus UnitPublisher::publish(const ObservationSample& s) noexcept {
  if (!finite(s.value) || !finite(s.predicted) || !finite(s.innovation) ||
      !finite(s.innovation_variance) || !finite(s.test_ratio)) {
    return reject(PublishStatus::kNonFinite);
  }
  if (s.innovation_variance < 0.0 || s.test_ratio < 0.0) {
    return reject(PublishStatus::kInvalidValue);
  }
  if (s.timestamp_ns < 0) return reject(PublishStatus::kInvalidTimestamp);
  hvac_twin_Observation& w = wire_->observation;
  if (!detail::copy_bounded(w.point, s.point, true)) return reject(PublishStatus::kInvalidName);
  w.value = s.value;
  w.quality = detail::to_wire(s.quality);
  w.exception_code = s.exception_code;
  w.predicted = s.predicted;
  w.innovation = s.innovation;
  w.innovation_variance = s.innovation_variance;
  w.test_ratio = s.test_ratio;
  w.fused = s.fused;
  w.timestamp_ns = s.timestamp_ns;
  w.cycle = s.cycle;
  return write(wire_->writer(Topic::kObservation), &w, s.timestamp_ns);
}

PublishStatus UnitPublisher::publish(const HealthSample& s) noexcept {
  if (!finite(s.cycle_time_ms) || !finite(s.cycle_time_max_ms)) {
    return reject(PublishStatus::kNonFinite);
  }
  if (s.cycle_time_ms < 0.0 || s.cycle_time_max_ms < 0.0) {
    return reject(PublishStatus::kInvalidValue);
  }
  if (s.timestamp_ns < 0) return reject(PublishStatus::kInvalidTimestamp);
  hvac_twin_EstimatorHealth& w = wire_->health;
  w.cycle = s.cycle;
  w.cycle_time_ms = s.cycle_time_ms;
  w.cycle_time_max_ms = s.cycle_time_max_ms;
  w.overruns = s.overruns;
  w.degraded_cycles = s.degraded_cycles;
  w.gate_rejections = s.gate_rejections;
  w.numerical_resets = s.numerical_resets;
  w.publish_rejections = stats().rejected();
  w.quality = detail::to_wire(s.quality);
  w.modbus_connected = s.modbus_connected;
  w.modbus_polls_ok = s.modbus_polls_ok;
  w.modbus_polls_exception = s.modbus_polls_exception;
  w.modbus_polls_failed = s.modbus_polls_failed;
  w.modbus_reconnects = s.modbus_reconnects;
  detail::copy_cut(w.modbus_last_error, s.modbus_last_error);
  w.timestamp_ns = s.timestamp_ns;
  return write(wire_->writer(Topic::kEstimatorHealth), &w, s.timestamp_ns);
}

PublishStatus UnitPublisher::publish(const LeakDiagnosticSample& s) noexcept {
  const double values[] = {s.charge,
                           s.charge_sigma,
                           s.nameplate_charge,
                           s.leak_rate,
                           s.leak_rate_sigma,
                           s.cusum,
                           s.rate_cusum,
                           s.charge_cusum,
                           s.threshold,
                           s.charge_reference,
                           s.false_alarm_interval_days};
  for (const double v : values) {
    if (!finite(v)) return reject(PublishStatus::kNonFinite);
  }
  if (s.charge_sigma < 0.0 || s.leak_rate_sigma < 0.0 || s.threshold < 0.0 ||
      s.false_alarm_interval_days < 0.0 || s.rate_cusum < 0.0 || s.charge_cusum < 0.0 ||
      s.charge_reference < 0.0) {
    return reject(PublishStatus::kInvalidValue);
  }
  if (s.timestamp_ns < 0 || s.suspect_since_ns < 0 || s.leak_since_ns < 0) {
    return reject(PublishStatus::kInvalidTimestamp);
  }
  hvac_twin_LeakDiagnostic& w = wire_->leak;
  w.state = detail::to_wire(s.state);
  w.hold = detail::to_wire(s.hold);
  w.charge = s.charge;
  w.charge_sigma = s.charge_sigma;
  w.nameplate_charge = s.nameplate_charge;
  w.leak_rate = s.leak_rate;
  w.leak_rate_sigma = s.leak_rate_sigma;
  w.cusum = s.cusum;
  w.rate_cusum = s.rate_cusum;
  w.charge_cusum = s.charge_cusum;
  w.charge_reference = s.charge_reference;
  w.threshold = s.threshold;
  w.false_alarm_interval_days = s.false_alarm_interval_days;
  w.decisions = s.decisions;
  w.suspect_since_ns = s.suspect_since_ns;
  w.leak_since_ns = s.leak_since_ns;
  w.quality = detail::to_wire(s.quality);
  w.timestamp_ns = s.timestamp_ns;
  w.cycle = s.cycle;
  return write(wire_->writer(Topic::kLeakDiagnostic), &w, s.timestamp_ns);
}

PublishStatus UnitPublisher::publish(const ConsistencySample& s) noexcept {
  const double values[] = {s.mean_nis, s.band_low, s.band_high, s.rejected_share};
  for (const double v : values) {
    if (!finite(v)) return reject(PublishStatus::kNonFinite);
    if (v < 0.0) return reject(PublishStatus::kInvalidValue);
  }
  if (s.rejected_share > 1.0) return reject(PublishStatus::kInvalidValue);
  if (s.timestamp_ns < 0) return reject(PublishStatus::kInvalidTimestamp);
  hvac_twin_EstimatorConsistency& w = wire_->consistency;
  if (!detail::copy_bounded(w.point, s.point, true)) return reject(PublishStatus::kInvalidName);
  w.window_cycles = s.window_cycles;
  w.samples = s.samples;
  w.mean_nis = s.mean_nis;
  w.band_low = s.band_low;
  w.band_high = s.band_high;
  w.verdict = detail::to_wire(s.verdict);
  w.rejected_share = s.rejected_share;
  w.timestamp_ns = s.timestamp_ns;
  w.cycle = s.cycle;
  return write(wire_->writer(Topic::kEstimatorConsistency), &w, s.timestamp_ns);
}

PublishStatus UnitPublisher::publish(const UnitEstimateSample& s) noexcept {
  if (s.estimates.size() > kMaxUnitEstimates) return reject(PublishStatus::kInvalidValue);
  for (const EstimateEntry& e : s.estimates) {
    if (!finite(e.value) || !finite(e.sigma)) return reject(PublishStatus::kNonFinite);
    if (e.sigma < 0.0) return reject(PublishStatus::kInvalidValue);
  }
  if (s.timestamp_ns < 0) return reject(PublishStatus::kInvalidTimestamp);
  hvac_twin_UnitEstimate& w = wire_->unit_estimate;
  std::size_t i = 0;
  for (const EstimateEntry& e : s.estimates) {
    hvac_twin_Estimate& to = w.estimates[i++];
    if (!detail::copy_bounded(to.name, e.name, true)) return reject(PublishStatus::kInvalidName);
    if (!detail::copy_bounded(to.eng_unit, e.eng_unit, false)) {
      return reject(PublishStatus::kInvalidUnit);
    }
    to.value = e.value;
    to.sigma = e.sigma;
  }
  for (std::size_t k = i; k < w.estimate_count; ++k)
    w.estimates[k] = hvac_twin_Estimate{};  // entries past the count are zero on the wire
  w.estimate_count = static_cast<std::uint32_t>(i);
  fill_cycle(s, w);
  return write(wire_->writer(Topic::kUnitEstimate), &w, s.timestamp_ns);
}

PublishStatus UnitPublisher::assert_liveliness() noexcept {
  PublishStatus status = PublishStatus::kOk;
  for (const Topic topic : kAllTopics) {
    if (wire_->writer(topic) == 0) continue;  // not created for this unit
    const dds_return_t rc = dds_assert_liveliness(wire_->writer(topic));
    if (rc != DDS_RETCODE_OK) {
      dds_errors_.fetch_add(1, std::memory_order_relaxed);
      last_dds_error_.store(rc, std::memory_order_relaxed);
      status = PublishStatus::kDdsError;
    }
  }
  return status;
}

PublisherStats UnitPublisher::stats() const noexcept {
  PublisherStats s;
  s.published = published_.load(std::memory_order_relaxed);
  s.rejected_non_finite = rejected_non_finite_.load(std::memory_order_relaxed);
  s.rejected_invalid = rejected_invalid_.load(std::memory_order_relaxed);
  s.dds_errors = dds_errors_.load(std::memory_order_relaxed);
  s.last_dds_error = last_dds_error_.load(std::memory_order_relaxed);
  return s;
}

}  // namespace hvac_twin::dds
