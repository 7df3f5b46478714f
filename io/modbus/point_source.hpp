// Where a unit's cycle gets its point values: the Modbus Poller on a live unit, a recording in
// hvac-twin-replay. The pipeline reads through this interface only, so a replay runs the very
// code the daemon runs.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>

#include "io/modbus/point_sample.hpp"

namespace hvac_twin::modbus {

class PointSource {
 public:
  virtual ~PointSource() = default;
  virtual void start() = 0;
  virtual void stop() = 0;
  // Copies the points into out[i] (configuration order) and the device status into *status (if
  // not null); returns the number of samples written. Cycle thread; no allocation, no throw.
  virtual std::size_t snapshot(std::span<PointSample> out, std::int64_t now_monotonic_ns,
                               DeviceStatus* status) const noexcept = 0;
};

}  // namespace hvac_twin::modbus
