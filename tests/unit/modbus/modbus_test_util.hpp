// Small helpers shared by the Modbus unit tests.
#pragma once

#include <chrono>
#include <string>
#include <thread>
#include <utility>

#include "config/config.hpp"

namespace hvac_twin::modbus::test {

inline config::PointConfig make_point(std::string name, config::RegisterKind kind,
                                      std::uint16_t address, config::ValueType type,
                                      config::WordOrder order = config::WordOrder::kABCD) {
  config::PointConfig p;
  p.name = std::move(name);
  p.kind = kind;
  p.address = address;
  p.type = type;
  p.word_order = order;
  p.range_min = -1e9;
  p.range_max = 1e9;
  return p;
}

inline config::PointConfig holding(std::string name, std::uint16_t address,
                                   config::ValueType type = config::ValueType::kUint16,
                                   config::WordOrder order = config::WordOrder::kABCD) {
  return make_point(std::move(name), config::RegisterKind::kHolding, address, type, order);
}

inline config::PointConfig input(std::string name, std::uint16_t address,
                                 config::ValueType type = config::ValueType::kUint16,
                                 config::WordOrder order = config::WordOrder::kABCD) {
  return make_point(std::move(name), config::RegisterKind::kInput, address, type, order);
}

// A device on the loopback test server with short, but not flaky, timings.
inline config::ModbusDeviceConfig fast_device(std::uint16_t port, int unit_id = 1) {
  config::ModbusDeviceConfig d;
  d.host = "127.0.0.1";
  d.port = port;
  d.unit_id = unit_id;
  d.poll_period_s = 0.25;
  d.response_timeout_s = 0.1;
  d.byte_timeout_s = 0.05;
  d.backoff_initial_s = 0.05;
  d.backoff_max_s = 0.3;
  return d;
}

// Polls `condition` every 5 ms until it holds or `timeout` passes; returns its last value.
// Tests assert conditions with generous timeouts instead of sleeping a fixed time.
template <typename Condition>
bool eventually(Condition condition,
                std::chrono::milliseconds timeout = std::chrono::milliseconds(10000)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    if (condition()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return condition();
}

}  // namespace hvac_twin::modbus::test
