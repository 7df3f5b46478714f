// Start-up validation of one device's configuration, as the poller needs it. Allocates; throws
// std::invalid_argument naming the first bad field. The config layer reports the same problems
// with JSON pointers; this is the poller's own guard, so that no caller can start a poller with a
// configuration it cannot honour. Any thread.
#pragma once

#include <span>

#include "config/config.hpp"

namespace hvac_twin::modbus {

// Checks: unit_id 0..255; port != 0; poll_period_s in (0, 86400]; 0 < response_timeout_s <
// poll_period_s / 2; 0 < byte_timeout_s < poll_period_s; 0 < backoff_initial_s <= backoff_max_s
// <= 3600; max_registers_per_request 1..125; at least one point; per point: word order legal for
// its type, scale finite and non-zero, offset finite, range finite with range_min <= range_max,
// stale_after_s > 0, registers inside 0..65535 and within one request.
void validate_device(const config::ModbusDeviceConfig& device,
                     std::span<const config::PointConfig> points);

}  // namespace hvac_twin::modbus
