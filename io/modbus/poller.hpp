// The poller of one Modbus TCP device: one thread, one connection, one request in flight.
//
// Every poll_period_s, on absolute CLOCK_MONOTONIC deadlines (missed deadlines are skipped and
// counted, never bunched), the thread reads every request of the plan (plan.hpp, exact
// contiguity) and decodes each point (decode.hpp). The estimator cycle never waits on it: it
// copies the latest values with snapshot().
//
// Error policy (shared/reliability.md):
//  - transport error (timeout, reset, refused, bad data, wrong transaction or unit id, ...):
//    modbus_close(), every point COMM_FAIL (last good value kept), reconnect after a jittered
//    exponential back-off (backoff_initial_s doubling up to backoff_max_s, +-25 % jitter, never
//    above backoff_max_s; reset to the initial value after a poll without transport error).
//    With backoff_initial_s < poll_period_s one transient fault costs exactly one failed poll.
//  - exception 0x06 (busy): the request is retried at most kBusyRetries times, kBusyRetryDelay
//    apart; still busy -> its points DEVICE_EXCEPTION(0x06).
//  - exception 0x0A/0x0B (gateway path / target failed): the unit behind the gateway is down:
//    every point DEVICE_EXCEPTION(code), the rest of this poll is skipped, no reconnect.
//  - any other exception (0x01-0x04, ...): that request's points DEVICE_EXCEPTION(code), no
//    reconnect; the other requests go on.
//  - decoded value not finite or outside [range_min, range_max]: OUT_OF_RANGE.
// A poll counts in DeviceStatus as ok (every request answered with data), exception (answered,
// but some request with an exception after the busy retries) or failed (transport or gateway).
//
// Threads: construct, start(), stop() and destroy from one owner thread; snapshot() from any
// thread at any time. The event callback runs on the poller thread.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "config/config.hpp"
#include "io/modbus/client.hpp"
#include "io/modbus/plan.hpp"
#include "io/modbus/point_source.hpp"
#include "io/modbus/quality.hpp"

namespace hvac_twin::modbus {

// CLOCK_MONOTONIC in nanoseconds: the time base of read_time_ns and snapshot()'s `now`.
std::int64_t monotonic_ns() noexcept;

enum class EventKind : std::uint8_t {
  kConnected,            // connection opened
  kConnectFailed,        // connect attempt failed (error_number, retry_in_s, attempt)
  kDisconnected,         // transport error: connection closed, all points COMM_FAIL
  kPointQualityChanged,  // one point's stored quality changed (point_index, old/new quality)
};

// One transition, for logging. Strings are valid only during the callback.
struct Event {
  EventKind kind = EventKind::kConnected;
  std::int64_t time_ns = 0;         // CLOCK_MONOTONIC [ns]
  int error_number = 0;             // kConnectFailed / kDisconnected
  std::uint8_t exception_code = 0;  // kPointQualityChanged to kDeviceException
  std::size_t point_index = 0;      // kPointQualityChanged: index into the points given
  PointQuality old_quality = PointQuality::kNotYetRead;
  PointQuality new_quality = PointQuality::kNotYetRead;
  std::uint64_t attempt = 0;    // kConnectFailed: consecutive failed attempts so far (1, 2, ...)
  double retry_in_s = 0.0;      // kConnectFailed / kDisconnected: delay before the next connect
  std::string_view point_name;  // kPointQualityChanged
  std::string_view message;     // human-readable summary
};

// Invoked on the poller thread; must not block for long and must not call stop(). Exceptions
// thrown by it are swallowed. Quality events are emitted for per-point causes only: entering
// COMM_FAIL (reported once by kDisconnected / kConnectFailed) and the normal NOT_YET_READ/COMM_FAIL
// -> GOOD recovery (reported by kConnected) are not repeated per point.
using EventCallback = std::function<void(const Event&)>;

class Poller final : public PointSource {
 public:
  static constexpr int kBusyRetries = 2;
  static constexpr std::chrono::milliseconds kBusyRetryDelay{20};

  // Start-up only: copies the configuration, validates it, plans the requests and resolves the
  // host. Throws std::invalid_argument with a message naming the bad field (unit id, timeouts,
  // response_timeout_s >= poll_period_s / 2, back-off, max_registers_per_request, a point's
  // word order, scale, offset, range or stale_after_s, a point past address 65535, no points).
  Poller(const config::ModbusDeviceConfig& device, std::span<const config::PointConfig> points,
         EventCallback on_event = {});
  ~Poller() override;  // stop()s
  Poller(const Poller&) = delete;
  Poller& operator=(const Poller&) = delete;

  // Starts the thread (may throw std::system_error). At most once per Poller.
  void start() override;
  // Asks the thread to stop and joins it. Returns within ~50 ms while the thread waits for a
  // deadline or backs off; a connect or read in progress finishes first, which is bounded by
  // response_timeout_s (+ byte timeouts). Idempotent. Closes the connection.
  void stop() override;

  // Copies the points into out[i] for i < min(out.size(), point_count()), in the order of the
  // `points` given to the constructor, and the device status into *status (if not null).
  // A GOOD point whose read is older than its stale_after_s at now_monotonic_ns is returned as
  // STALE. Any thread; takes a mutex held only for a copy (never across I/O); no allocation.
  // Returns the number of samples written.
  std::size_t snapshot(std::span<PointSample> out, std::int64_t now_monotonic_ns,
                       DeviceStatus* status) const noexcept override;

  std::size_t point_count() const noexcept { return points_.size(); }
  const RequestPlan& plan() const noexcept { return plan_; }
  const config::ModbusDeviceConfig& device() const noexcept { return device_; }

 private:
  enum class PollResult : std::uint8_t { kOk, kTransportError, kGatewayFailure, kStopped };

  void run() noexcept;
  bool try_connect() noexcept;
  PollResult poll_once() noexcept;
  ReadResult read_with_busy_retry(const ReadRequest& request) noexcept;
  void apply_data(const ReadRequest& request, std::int64_t read_time) noexcept;
  void mark_points(std::size_t first, std::size_t count, PointQuality q,
                   std::uint8_t code) noexcept;  // by plan slot
  void mark_all(PointQuality q, std::uint8_t code) noexcept;
  void set_point(std::size_t index, const PointSample& next, std::string_view detail) noexcept;
  void on_transport_error(int error_number, std::int64_t now) noexcept;
  void record_error(int error_number, const char* text) noexcept;
  double next_backoff_delay() noexcept;
  void publish() noexcept;
  void emit(const Event& event) noexcept;
  bool wait_until(std::int64_t deadline_ns) noexcept;  // false when stop was requested
  bool wait_for(std::chrono::nanoseconds delay) noexcept;

  config::ModbusDeviceConfig device_;
  std::vector<config::PointConfig> points_;
  RequestPlan plan_;
  EventCallback on_event_;
  std::unique_ptr<Client> client_;

  // Poller-thread state.
  std::vector<PointSample> work_;
  DeviceStatus work_status_;
  std::vector<std::uint16_t> registers_;      // kMaxRegistersPerRead
  std::vector<std::int64_t> stale_after_ns_;  // per point
  double backoff_s_ = 0.0;
  std::int64_t next_connect_ns_ = 0;
  std::uint64_t connect_failures_in_row_ = 0;
  bool ever_connected_ = false;
  std::uint64_t rng_state_ = 0;

  // Shared with snapshot().
  mutable std::mutex mutex_;
  std::vector<PointSample> shared_;
  DeviceStatus shared_status_;

  // Stop signalling.
  std::mutex wait_mutex_;
  std::condition_variable wake_;
  bool stop_requested_ = false;         // guarded by wait_mutex_
  std::atomic<bool> stop_flag_{false};  // the same, readable without the lock
  std::thread thread_;
  bool started_ = false;
};

}  // namespace hvac_twin::modbus
