// Cycle supervision for every unit of the daemon.
//
// Liveness to systemd: WATCHDOG=1 is sent from the end of a completed cycle, and only when every
// unit has completed a cycle since the previous ping and none has overrun its deadline
// `overrun_limit` times in a row. A hung or persistently late estimator therefore stops the
// pings and systemd restarts the service; a free-running timer would hide it. The moment the
// overruns start withholding the pings, and the moment they stop doing so, are reported once
// each through on_pings (the daemon logs them).
//
// Hang detection: a thread checks that no cycle has been running longer than hang_timeout. A hung
// cycle is reported once through the callback; with hang_exit the process then exits with
// status 70 (EX_SOFTWARE) so that its supervisor (systemd's Restart=on-failure) restarts it even
// when no systemd watchdog is configured.
// Time the cycle's thread spent runnable but waiting for a CPU (the kernel's run-queue delay,
// /proc/self/task/<tid>/schedstat) does not count: a cycle starved by an overloaded CPU is late
// (an overrun, counted and reported), not hung. A deadlocked cycle sleeps and one in an endless
// loop runs; both still count. Without it, 200 heat-pump units starting together on one core
// shared it until one first cycle had taken 30 s of wall time, and the daemon exited 70 at start
// (scale_bench; under systemd a restart loop) instead of running late.
//
// Threads: cycle_started()/cycle_finished() from each unit's cycle thread (a short lock, no
// allocation); start()/stop() from the owner. on_hang runs on the supervisor thread; on_pings on
// the cycle thread inside cycle_finished(), after the lock is released.
#pragma once

#include <sys/types.h>

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "daemon/runtime/notify.hpp"

namespace hvac_twin::runtime {

// The kernel's run-queue delay of thread `tid` of this process so far [ns] (the second field of
// /proc/self/task/<tid>/schedstat); -1 if unavailable. No allocation.
std::int64_t thread_runqueue_wait_ns(pid_t tid);

struct SupervisorOptions {
  std::int64_t hang_timeout_ns = 30'000'000'000;
  bool hang_exit = true;
  int overrun_limit = 3;                  // consecutive overruns that stop the pings
  std::int64_t min_ping_interval_ns = 0;  // pings no more often than this
  std::int64_t check_interval_ns = 100'000'000;
  // The run-queue delay of a thread so far [ns], or -1 if unknown (then a cycle's wall time is
  // its running time); default: the kernel's schedstat. Tests put in their own.
  std::function<std::int64_t(pid_t)> runqueue_wait_ns = thread_runqueue_wait_ns;
};

// A change in whether overruns withhold the pings. Only the unit whose cycle just finished can
// cause one: its overrun count reaching the limit (stopped), or its first cycle on time again
// while no other unit is over the limit (resumed).
struct PingChange {
  bool stopped = false;          // true: pings now withheld; false: no longer withheld
  std::size_t unit = 0;          // the unit whose cycle caused the change
  int consecutive_overruns = 0;  // that unit's overruns in a row (resumed: before this cycle)
  std::int64_t withheld_ns = 0;  // resumed: how long the pings were withheld [ns]
};

class CycleSupervisor {
 public:
  // on_hang(unit, running_for_ns) is called once per hung cycle, before a hang_exit.
  // on_pings(change) is called once when overruns start withholding the pings and once when
  // they stop doing so.
  CycleSupervisor(std::size_t units, const SystemdNotifier& notifier, SupervisorOptions options,
                  std::function<void(std::size_t, std::int64_t)> on_hang,
                  std::function<void(const PingChange&)> on_pings = {});
  ~CycleSupervisor();
  CycleSupervisor(const CycleSupervisor&) = delete;
  CycleSupervisor& operator=(const CycleSupervisor&) = delete;

  void start();
  void stop();

  // From a unit's cycle thread before its first cycle: the thread whose run-queue delay is
  // discounted from that unit's cycles (none registered: wall time only).
  void attach_thread(std::size_t unit, pid_t tid);
  void cycle_started(std::size_t unit, std::int64_t now_ns);
  // Returns true when this call sent WATCHDOG=1.
  bool cycle_finished(std::size_t unit, std::int64_t now_ns, bool overrun);

  [[nodiscard]] std::uint64_t pings() const { return pings_.load(); }
  [[nodiscard]] std::uint64_t hangs() const { return hangs_.load(); }
  [[nodiscard]] bool pings_withheld() const;  // some unit is over its overrun limit

 private:
  struct UnitState {
    std::atomic<std::int64_t> cycle_start_ns{0};  // 0 = not in a cycle
    std::atomic<pid_t> tid{0};                    // the cycle thread; 0 = not attached
    bool hang_reported = false;                   // supervisor thread only
    // Supervisor thread only: the cycle it last saw start, and its thread's run-queue delay then.
    std::int64_t seen_start_ns = 0;
    std::int64_t wait_at_seen_ns = -1;
    bool progressed = false;       // guarded by mutex_
    int consecutive_overruns = 0;  // guarded by mutex_
  };
  void run();

  const SystemdNotifier& notifier_;
  SupervisorOptions options_;
  std::function<void(std::size_t, std::int64_t)> on_hang_;
  std::function<void(const PingChange&)> on_pings_;
  std::unique_ptr<UnitState[]> units_;
  std::size_t count_;
  mutable std::mutex mutex_;
  std::int64_t last_ping_ns_ = 0;
  std::int64_t withheld_since_ns_ = -1;  // guarded by mutex_; -1 = pings not withheld
  std::atomic<std::uint64_t> pings_{0};
  std::atomic<std::uint64_t> hangs_{0};
  std::mutex stop_mutex_;
  std::condition_variable stop_cv_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace hvac_twin::runtime
