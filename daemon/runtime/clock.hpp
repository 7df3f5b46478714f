// The runtime's clocks. Only daemon/runtime reads clocks; the estimation core gets time passed in.
#pragma once

#include <cstdint>
#include <ctime>

namespace hvac_twin::runtime {

inline std::int64_t read_clock_ns(clockid_t id) noexcept {
  timespec ts{};
  clock_gettime(id, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}
// CLOCK_MONOTONIC [ns]: deadlines, ages, cycle times (same base as modbus::monotonic_ns()).
inline std::int64_t monotonic_ns() noexcept {
  return read_clock_ns(CLOCK_MONOTONIC);
}
// CLOCK_REALTIME [ns since the Unix epoch]: sample timestamps for subscribers.
inline std::int64_t realtime_ns() noexcept {
  return read_clock_ns(CLOCK_REALTIME);
}

}  // namespace hvac_twin::runtime
