#include "daemon/runtime/supervisor.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>

#include "daemon/runtime/clock.hpp"

namespace hvac_twin::runtime {

CycleSupervisor::CycleSupervisor(std::size_t units, const SystemdNotifier& notifier,
                                 SupervisorOptions options,
                                 std::function<void(std::size_t, std::int64_t)> on_hang,
                                 std::function<void(const PingChange&)> on_pings)
    : notifier_(notifier),
      options_(options),
      on_hang_(std::move(on_hang)),
      on_pings_(std::move(on_pings)),
      units_(new UnitState[units]),
      count_(units) {}

CycleSupervisor::~CycleSupervisor() {
  stop();
}

void CycleSupervisor::start() {
  thread_ = std::thread([this] { run(); });
}

void CycleSupervisor::stop() {
  {
    std::lock_guard lock(stop_mutex_);
    stop_ = true;
  }
  stop_cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

std::int64_t thread_runqueue_wait_ns(pid_t tid) {
  char path[64];
  std::snprintf(path, sizeof path, "/proc/self/task/%d/schedstat", static_cast<int>(tid));
  const int fd = ::open(path, O_RDONLY | O_CLOEXEC);
  if (fd < 0) return -1;
  char text[128];
  const ssize_t n = ::read(fd, text, sizeof text - 1);
  ::close(fd);
  if (n <= 0) return -1;
  text[n] = '\0';
  // "<ns on the CPU> <ns waiting on a run queue> <timeslices>"
  char* end = nullptr;
  std::strtoll(text, &end, 10);
  if (end == text) return -1;
  char* const wait_begin = end;
  const long long wait = std::strtoll(wait_begin, &end, 10);
  return end == wait_begin || wait < 0 ? -1 : static_cast<std::int64_t>(wait);
}

void CycleSupervisor::attach_thread(std::size_t unit, pid_t tid) {
  units_[unit].tid.store(tid);
}

void CycleSupervisor::cycle_started(std::size_t unit, std::int64_t now_ns) {
  units_[unit].cycle_start_ns.store(now_ns == 0 ? 1 : now_ns);
}

bool CycleSupervisor::cycle_finished(std::size_t unit, std::int64_t now_ns, bool overrun) {
  units_[unit].cycle_start_ns.store(0);
  PingChange change;
  bool changed = false;
  bool pinged = false;
  {
    std::lock_guard lock(mutex_);
    UnitState& u = units_[unit];
    change.unit = unit;
    change.consecutive_overruns = u.consecutive_overruns;
    u.consecutive_overruns = overrun ? u.consecutive_overruns + 1 : 0;
    u.progressed = true;
    bool withheld = false, all_progressed = true;
    for (std::size_t i = 0; i < count_; ++i) {
      withheld = withheld || units_[i].consecutive_overruns >= options_.overrun_limit;
      all_progressed = all_progressed && units_[i].progressed;
    }
    if (withheld != (withheld_since_ns_ >= 0)) {
      changed = true;
      change.stopped = withheld;
      if (withheld) {
        change.consecutive_overruns = u.consecutive_overruns;
        withheld_since_ns_ = now_ns;
      } else {
        change.withheld_ns = now_ns - withheld_since_ns_;
        withheld_since_ns_ = -1;
      }
    }
    if (!withheld && all_progressed &&
        (last_ping_ns_ == 0 || now_ns - last_ping_ns_ >= options_.min_ping_interval_ns)) {
      for (std::size_t i = 0; i < count_; ++i)
        units_[i].progressed = false;
      last_ping_ns_ = now_ns;
      notifier_.watchdog();
      pings_.fetch_add(1);
      pinged = true;
    }
  }
  if (changed && on_pings_) on_pings_(change);
  return pinged;
}

bool CycleSupervisor::pings_withheld() const {
  std::lock_guard lock(mutex_);
  return withheld_since_ns_ >= 0;
}

void CycleSupervisor::run() {
  std::unique_lock lock(stop_mutex_);
  while (!stop_) {
    stop_cv_.wait_for(lock, std::chrono::nanoseconds(options_.check_interval_ns),
                      [this] { return stop_; });
    if (stop_) break;
    const std::int64_t now = monotonic_ns();
    for (std::size_t i = 0; i < count_; ++i) {
      UnitState& u = units_[i];
      const std::int64_t started = u.cycle_start_ns.load();
      if (started == 0) {
        u.hang_reported = false;
        continue;
      }
      const pid_t tid = u.tid.load();
      const auto waited_so_far = [&]() -> std::int64_t {
        return tid != 0 && options_.runqueue_wait_ns ? options_.runqueue_wait_ns(tid) : -1;
      };
      if (started != u.seen_start_ns) {  // a new cycle: its thread's run-queue delay from here
        u.seen_start_ns = started;
        u.wait_at_seen_ns = waited_so_far();
      }
      std::int64_t running = now - started;
      if (running <= options_.hang_timeout_ns || u.hang_reported) continue;
      if (u.wait_at_seen_ns >= 0) {  // starved, not hung: the time it waited for a CPU
        const std::int64_t waited = waited_so_far();
        if (waited >= u.wait_at_seen_ns) running -= waited - u.wait_at_seen_ns;
        if (running <= options_.hang_timeout_ns) continue;
      }
      u.hang_reported = true;
      hangs_.fetch_add(1);
      if (on_hang_) on_hang_(i, running);
      if (options_.hang_exit) _exit(70);  // EX_SOFTWARE: let the service manager restart us
    }
  }
}

}  // namespace hvac_twin::runtime
