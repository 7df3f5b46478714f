// The daemon: one DDS participant, one UnitPipeline and cycle thread per configured unit, and the
// cycle supervisor that feeds systemd's watchdog. Start-up and shut-down only; the cycles run on
// their own threads.
#pragma once

#include <spdlog/logger.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "config/config.hpp"
#include "daemon/runtime/notify.hpp"
#include "daemon/runtime/repeat_log.hpp"
#include "daemon/runtime/scheduler.hpp"
#include "daemon/runtime/supervisor.hpp"
#include "daemon/runtime/unit_pipeline.hpp"
#include "io/dds/participant.hpp"

namespace hvac_twin::runtime {

// A warning that would repeat every cycle (a cycle over its deadline) is logged at most once per
// this much wall time, with a count (RepeatLog).
inline constexpr std::int64_t kRepeatLogIntervalNs = 60'000'000'000;

class Daemon {
 public:
  Daemon(config::Config config, std::shared_ptr<spdlog::logger> log, CycleHooks* hooks = nullptr);
  ~Daemon();
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  // Builds DDS, models, filters and pollers, then starts the cycle threads. Throws with a message
  // naming what failed. Sends READY=1 when everything runs.
  void start();
  // Stops the cycles (a waiting cycle thread wakes at once), the pollers and DDS. Idempotent.
  void stop();

 private:
  void run_unit(std::size_t index);
  // Logs, once each, that overruns stopped the watchdog pings (warning) and that they resumed.
  void log_ping_change(const PingChange& change) const;
  // The first overrun of an episode, a summary per kRepeatLogIntervalNs, and the episode's end.
  void log_overruns(const std::string& unit, std::uint64_t cycle, const RepeatStep& step) const;

  config::Config config_;
  std::shared_ptr<spdlog::logger> log_;
  CycleHooks* hooks_;  // null but in fault-injection tests
  SystemdNotifier notifier_;
  std::unique_ptr<dds::Participant> participant_;
  std::vector<std::unique_ptr<UnitPipeline>> pipelines_;
  std::vector<std::unique_ptr<FixedRateScheduler>> schedulers_;
  std::unique_ptr<CycleSupervisor> supervisor_;
  std::vector<std::thread> threads_;
  bool running_ = false;
};

}  // namespace hvac_twin::runtime
