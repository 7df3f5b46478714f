// Records as the Subscriber delivers them, for the hvac-twin-web tests that feed the Store and
// the Dashboard directly (the DDS path itself is tested against real readers and the daemon).
#pragma once

#include <cstdint>
#include <string>

#include "io/dds/subscriber.hpp"

namespace hvac_twin::web::test {

inline constexpr std::int64_t kStamp0 = 1'700'000'000'000'000'000;  // ns, 2023-11-14
inline constexpr std::int64_t kSecond = 1'000'000'000;

inline dds::HealthRecord health(const std::string& unit, std::uint64_t cycle, std::int64_t t_ns) {
  dds::HealthRecord h;
  h.site = std::string("site");
  h.unit = unit;
  h.cycle = cycle;
  h.cycle_time_ms = 12.5;
  h.quality = dds::EstimateQuality::kGood;
  h.modbus_connected = true;
  h.timestamp_ns = t_ns;
  return h;
}

inline dds::VirtualSensorRecord sensor(const std::string& unit, const std::string& name,
                                       double value, double sigma, std::int64_t t_ns) {
  dds::VirtualSensorRecord r;
  r.site = std::string("site");
  r.unit = unit;
  r.name = name;
  r.value = value;
  r.sigma = sigma;
  r.eng_unit = std::string("K");
  r.quality = dds::EstimateQuality::kGood;
  r.timestamp_ns = t_ns;
  return r;
}

inline dds::LeakDiagnosticRecord leak(const std::string& unit, dds::LeakState state,
                                      std::int64_t t_ns) {
  dds::LeakDiagnosticRecord r;
  r.site = std::string("site");
  r.unit = unit;
  r.state = state;
  r.hold = dds::LeakHold::kNone;
  r.charge = 0.48;
  r.charge_sigma = 0.02;
  r.nameplate_charge = 0.5;
  r.rate_cusum = 3.0;
  r.charge_cusum = 1.0;
  r.cusum = 3.0;
  r.threshold = 6.9;
  r.quality = dds::EstimateQuality::kGood;
  r.timestamp_ns = t_ns;
  return r;
}

inline dds::ObservationRecord observation(const std::string& unit, const std::string& point,
                                          std::int64_t t_ns) {
  dds::ObservationRecord r;
  r.site = std::string("site");
  r.unit = unit;
  r.point = point;
  r.value = 101.0;
  r.quality = dds::PointQuality::kGood;
  r.predicted = 100.0;
  r.innovation = 1.0;
  r.innovation_variance = 4.0;
  r.test_ratio = 0.25;
  r.fused = true;
  r.timestamp_ns = t_ns;
  return r;
}

}  // namespace hvac_twin::web::test
