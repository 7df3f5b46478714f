#include "io/modbus/poller.hpp"

#include <pthread.h>
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "io/modbus/decode.hpp"
#include "io/modbus/validate.hpp"

namespace hvac_twin::modbus {
namespace {

constexpr std::uint8_t kExceptionBusy = 0x06;
constexpr std::uint8_t kExceptionGatewayPath = 0x0A;
constexpr std::uint8_t kExceptionGatewayTarget = 0x0B;

std::int64_t seconds_to_ns(double s) noexcept {
  return std::llround(s * 1e9);
}

// splitmix64: jitter only, no allocation, not cryptographic.
std::uint64_t next_random(std::uint64_t& state) noexcept {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// Per-point causes only; see EventCallback.
bool worth_reporting(const PointSample& before, const PointSample& after) noexcept {
  if (before.quality == after.quality && before.exception_code == after.exception_code) {
    return false;
  }
  if (after.quality == PointQuality::kCommFail) return false;
  if (after.quality == PointQuality::kGood &&
      (before.quality == PointQuality::kNotYetRead || before.quality == PointQuality::kCommFail)) {
    return false;
  }
  return true;
}

const char* kind_name(config::RegisterKind kind) noexcept {
  return kind == config::RegisterKind::kInput ? "input" : "holding";
}

}  // namespace

std::int64_t monotonic_ns() noexcept {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

Poller::Poller(const config::ModbusDeviceConfig& device,
               std::span<const config::PointConfig> points, EventCallback on_event)
    : device_(device), points_(points.begin(), points.end()), on_event_(std::move(on_event)) {
  validate_device(device_, points_);
  plan_ = make_plan(points_, PlanOptions{device_.max_registers_per_request, 0});
  client_ = std::make_unique<Client>(device_);
  work_.resize(points_.size());
  shared_.resize(points_.size());
  registers_.resize(kMaxRegistersPerRead);
  stale_after_ns_.reserve(points_.size());
  for (const auto& p : points_)
    stale_after_ns_.push_back(seconds_to_ns(p.stale_after_s));
  backoff_s_ = device_.backoff_initial_s;
  rng_state_ = static_cast<std::uint64_t>(monotonic_ns()) ^ reinterpret_cast<std::uintptr_t>(this);
}

Poller::~Poller() {
  stop();
}

void Poller::start() {
  if (started_) throw std::logic_error("modbus: Poller::start() called twice");
  started_ = true;
  work_status_.running = true;
  publish();
  thread_ = std::thread([this] { run(); });
}

void Poller::stop() {
  if (!thread_.joinable()) return;
  {
    std::lock_guard<std::mutex> lock(wait_mutex_);
    stop_requested_ = true;
  }
  stop_flag_.store(true);
  wake_.notify_all();
  thread_.join();
}

std::size_t Poller::snapshot(std::span<PointSample> out, std::int64_t now_monotonic_ns,
                             DeviceStatus* status) const noexcept {
  std::size_t n = 0;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    n = std::min(out.size(), shared_.size());
    std::copy_n(shared_.begin(), n, out.begin());
    if (status != nullptr) *status = shared_status_;
  }
  for (std::size_t i = 0; i < n; ++i) {
    if (out[i].quality == PointQuality::kGood &&
        now_monotonic_ns - out[i].read_time_ns > stale_after_ns_[i]) {
      out[i].quality = PointQuality::kStale;
    }
  }
  return n;
}

void Poller::run() noexcept {
  pthread_setname_np(pthread_self(), "hvac-modbus");  // shows in top -H / gdb
  const std::int64_t period = seconds_to_ns(device_.poll_period_s);
  std::int64_t next_poll = monotonic_ns();
  next_connect_ns_ = next_poll;
  for (;;) {
    std::int64_t now = monotonic_ns();
    if (!client_->is_connected() && now >= next_connect_ns_) {
      try_connect();
      now = monotonic_ns();
    }
    if (stop_flag_.load()) break;
    if (now >= next_poll) {
      if (client_->is_connected()) {
        if (poll_once() == PollResult::kStopped) break;
      } else {
        ++work_status_.polls_failed;  // device down: points already COMM_FAIL
      }
      next_poll += period;
      now = monotonic_ns();
      if (now >= next_poll) {  // overran: skip the missed deadlines, keep the phase
        const std::int64_t missed = (now - next_poll) / period + 1;
        next_poll += missed * period;
        work_status_.deadline_misses += static_cast<std::uint64_t>(missed);
      }
      publish();
    }
    std::int64_t wake_at = next_poll;
    if (!client_->is_connected()) wake_at = std::min(wake_at, next_connect_ns_);
    if (!wait_until(wake_at)) break;
  }
  client_->close();
  work_status_.connected = false;
  work_status_.running = false;
  publish();
}

bool Poller::try_connect() noexcept {
  ++work_status_.connect_attempts;
  const int error = client_->connect();
  const std::int64_t t = monotonic_ns();
  char text[160];
  if (error == 0) {
    if (ever_connected_) ++work_status_.reconnects;
    ever_connected_ = true;
    connect_failures_in_row_ = 0;
    work_status_.connected = true;
    publish();
    std::snprintf(text, sizeof text, "connected to %s:%u unit %d", client_->ip_address().c_str(),
                  unsigned{client_->port()}, device_.unit_id);
    Event e;
    e.kind = EventKind::kConnected;
    e.time_ns = t;
    e.message = text;
    emit(e);
    return true;
  }
  ++work_status_.connect_failures;
  ++connect_failures_in_row_;
  record_error(error, error_text(error));
  work_status_.connected = false;
  mark_all(PointQuality::kCommFail, 0);
  const double delay = next_backoff_delay();
  next_connect_ns_ = t + seconds_to_ns(delay);
  publish();
  std::snprintf(text, sizeof text, "connect to %s:%u failed: %s; retry in %.2f s",
                client_->ip_address().c_str(), unsigned{client_->port()}, error_text(error), delay);
  Event e;
  e.kind = EventKind::kConnectFailed;
  e.time_ns = t;
  e.error_number = error;
  e.attempt = connect_failures_in_row_;
  e.retry_in_s = delay;
  e.message = text;
  emit(e);
  return false;
}

Poller::PollResult Poller::poll_once() noexcept {
  bool exception = false;  // a request answered with an exception: its points failed
  for (const ReadRequest& request : plan_.requests) {
    if (stop_flag_.load()) return PollResult::kStopped;
    const ReadResult r = read_with_busy_retry(request);
    const std::int64_t t = monotonic_ns();
    if (r.outcome == ReadOutcome::kOk) {
      ++work_status_.requests_ok;
      apply_data(request, t);
    } else if (r.outcome == ReadOutcome::kException) {
      ++work_status_.requests_failed;
      char text[96];
      std::snprintf(text, sizeof text, "exception 0x%02X reading %s %u+%u",
                    unsigned{r.exception_code}, kind_name(request.kind), unsigned{request.address},
                    unsigned{request.count});
      record_error(kModbusErrnoBase + r.exception_code, text);
      if (r.exception_code == kExceptionGatewayPath ||
          r.exception_code == kExceptionGatewayTarget) {
        mark_all(PointQuality::kDeviceException, r.exception_code);
        ++work_status_.polls_failed;
        backoff_s_ = device_.backoff_initial_s;  // the link itself works
        publish();
        return PollResult::kGatewayFailure;
      }
      mark_points(request.first_point, request.point_count, PointQuality::kDeviceException,
                  r.exception_code);
      exception = true;
    } else {
      ++work_status_.requests_failed;
      ++work_status_.polls_failed;
      on_transport_error(r.error_number, t);
      return PollResult::kTransportError;
    }
    publish();
  }
  if (exception) {
    ++work_status_.polls_exception;
  } else {
    ++work_status_.polls_ok;
    work_status_.last_poll_ok_ns = monotonic_ns();
  }
  backoff_s_ = device_.backoff_initial_s;  // the device answered: the link works
  publish();
  return PollResult::kOk;
}

ReadResult Poller::read_with_busy_retry(const ReadRequest& request) noexcept {
  for (int attempt = 0;; ++attempt) {
    const ReadResult r = client_->read(request.kind, request.address, request.count, registers_);
    if (r.outcome != ReadOutcome::kException) return r;
    ++work_status_.exceptions;
    if (r.exception_code != kExceptionBusy || attempt >= kBusyRetries) return r;
    ++work_status_.busy_retries;
    if (!wait_for(kBusyRetryDelay)) return r;
  }
}

void Poller::apply_data(const ReadRequest& request, std::int64_t read_time) noexcept {
  for (std::size_t k = request.first_point; k < request.first_point + request.point_count; ++k) {
    const PlannedPoint& slot = plan_.points[k];
    const config::PointConfig& cfg = points_[slot.point_index];
    const DecodeResult d =
        decode(std::span<const std::uint16_t>(registers_.data() + slot.offset, slot.count), cfg);
    PointSample next = work_[slot.point_index];
    next.exception_code = 0;
    char detail[128];
    if (d.status == DecodeStatus::kOk) {
      next.value = d.value;
      next.quality = PointQuality::kGood;
      next.read_time_ns = read_time;
      detail[0] = '\0';
    } else {
      next.quality = PointQuality::kOutOfRange;
      if (d.status == DecodeStatus::kOutOfRange) {
        std::snprintf(detail, sizeof detail, "value %g outside [%g, %g]", d.value, cfg.range_min,
                      cfg.range_max);
      } else {
        std::snprintf(detail, sizeof detail, "%s", to_string(d.status).data());
      }
    }
    set_point(slot.point_index, next, detail);
  }
}

void Poller::mark_points(std::size_t first, std::size_t count, PointQuality q,
                         std::uint8_t code) noexcept {
  for (std::size_t k = first; k < first + count; ++k) {
    const std::size_t index = plan_.points[k].point_index;
    PointSample next = work_[index];
    next.quality = q;
    next.exception_code = code;
    set_point(index, next, work_status_.last_error);
  }
}

void Poller::mark_all(PointQuality q, std::uint8_t code) noexcept {
  mark_points(0, plan_.points.size(), q, code);
}

void Poller::set_point(std::size_t index, const PointSample& next,
                       std::string_view detail) noexcept {
  const PointSample before = work_[index];
  work_[index] = next;
  if (!on_event_ || !worth_reporting(before, next)) return;
  char text[256];
  std::snprintf(text, sizeof text, "point %s: %s -> %s%s%.*s", points_[index].name.c_str(),
                to_string(before.quality).data(), to_string(next.quality).data(),
                detail.empty() ? "" : ": ", static_cast<int>(detail.size()), detail.data());
  Event e;
  e.kind = EventKind::kPointQualityChanged;
  e.time_ns = monotonic_ns();
  e.exception_code = next.exception_code;
  e.point_index = index;
  e.old_quality = before.quality;
  e.new_quality = next.quality;
  e.point_name = points_[index].name;
  e.message = text;
  emit(e);
}

void Poller::on_transport_error(int error_number, std::int64_t now) noexcept {
  client_->close();
  ++work_status_.transport_errors;
  record_error(error_number, error_text(error_number));
  work_status_.connected = false;
  mark_all(PointQuality::kCommFail, 0);
  const double delay = next_backoff_delay();
  next_connect_ns_ = now + seconds_to_ns(delay);
  publish();
  char text[160];
  std::snprintf(text, sizeof text, "transport error: %s; connection closed, reconnect in %.2f s",
                error_text(error_number), delay);
  Event e;
  e.kind = EventKind::kDisconnected;
  e.time_ns = now;
  e.error_number = error_number;
  e.retry_in_s = delay;
  e.message = text;
  emit(e);
}

void Poller::record_error(int error_number, const char* text) noexcept {
  work_status_.last_error_number = error_number;
  std::snprintf(work_status_.last_error, sizeof work_status_.last_error, "%s", text);
}

double Poller::next_backoff_delay() noexcept {
  const double u = static_cast<double>(next_random(rng_state_) >> 11) * 0x1.0p-53;  // [0, 1)
  const double delay = std::min(backoff_s_ * (0.75 + 0.5 * u), device_.backoff_max_s);
  backoff_s_ = std::min(backoff_s_ * 2.0, device_.backoff_max_s);
  return delay;
}

void Poller::publish() noexcept {
  std::lock_guard<std::mutex> lock(mutex_);
  std::copy(work_.begin(), work_.end(), shared_.begin());
  shared_status_ = work_status_;
}

void Poller::emit(const Event& event) noexcept {
  if (!on_event_) return;
  try {
    on_event_(event);
  } catch (...) {
    // A logging callback must not take the poller down.
  }
}

bool Poller::wait_until(std::int64_t deadline_ns) noexcept {
  std::unique_lock<std::mutex> lock(wait_mutex_);
  while (!stop_requested_) {
    const std::int64_t now = monotonic_ns();
    if (now >= deadline_ns) return true;
    wake_.wait_for(lock, std::chrono::nanoseconds(deadline_ns - now));
  }
  return false;
}

bool Poller::wait_for(std::chrono::nanoseconds delay) noexcept {
  return wait_until(monotonic_ns() + delay.count());
}

}  // namespace hvac_twin::modbus
