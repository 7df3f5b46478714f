// Bounds on configuration values (internal to config/). Generous for any real plant; they
// exist so that the runtime can turn every duration into integer nanoseconds without overflow
// and so that a typo (3600000 instead of 3600) is caught. config/README.md lists them.
#pragma once

#include <cstddef>
#include <cstdint>

namespace hvac_twin::config::detail {

inline constexpr std::size_t kMaxNameLength = 64;    // ids, names, topic prefix, interface
inline constexpr std::size_t kMaxPathLength = 4096;  // state_directory (PATH_MAX)
inline constexpr double kMinPollPeriodS = 1e-3;      // modbus.poll_period_s: a device-down
inline constexpr double kMaxPollPeriodS = 3600.0;    //   poller wakes once a period
inline constexpr double kMaxTimeoutS = 60.0;         // response and byte timeouts
inline constexpr double kMaxBackoffS = 3600.0;       // reconnect back-off
inline constexpr double kMaxStaleAfterS = 86400.0;   // points[].stale_after_s
inline constexpr double kMaxStuckAfterS = 604800.0;  // points[].stuck_after_s (a week)
inline constexpr double kMaxPeriodS = 86400.0;       // estimator.period_s (model time)
inline constexpr double kMaxDeadlineS = 3600.0;      // estimator.deadline_s
inline constexpr double kMinTimeScale = 1e-3;        // runtime.time_scale: period_s / time_scale
inline constexpr double kMaxTimeScale = 1e6;         //   stays below 1e8 s (int64 nanoseconds)
inline constexpr double kMaxHangTimeoutS = 86400.0;  // runtime.hang_timeout_s
inline constexpr int kMaxConsecutiveRejections = 1000000;
inline constexpr long kMaxConsistencyWindowCycles = 100000;  // consistency_window_s / period_s

// What start-up would refuse. The runtime counts the poll period, the wall-clock cycle period
// (period_s / time_scale) and the deadline in whole nanoseconds; DDS takes a period of at most
// 24 h; the points fused in a cycle are published as a 64-bit mask.
inline constexpr double kMinTickS = 1e-9;
inline constexpr double kMaxWallPeriodS = 86400.0;
inline constexpr std::size_t kMaxMeasuredPoints = 64;  // per unit

// A model's states and outputs (an FMU's are the file's): the filters' matrices are dense, n x n
// and m x n doubles (at 1000 states each n x n matrix is 8 MB; the heat pump at its finest
// 40 cells has 169 states).
inline constexpr std::size_t kMaxModelStates = 1000;
inline constexpr std::size_t kMaxModelOutputs = 1000;

// Upper bounds of initial_std (the state's range) and process_noise (the range over
// sqrt(kProcessNoiseSpanS): a random walk spanning it in an hour); kMaxUnboundedStd for both
// when the state has no finite range.
inline constexpr double kProcessNoiseSpanS = 3600.0;
inline constexpr double kMaxUnboundedStd = 1e6;

// A unit's recording budget: up to 1 TiB [MiB].
inline constexpr std::int64_t kMaxRecordingBudgetMib = 1 << 20;

}  // namespace hvac_twin::config::detail
