// The daemon: one DDS participant, one UnitPipeline and cycle thread per configured unit, and the
// cycle supervisor that feeds systemd's watchdog. Start-up and shut-down only; the cycles run on
// their own threads.
#pragma once

#include <spdlog/logger.h>

#include <atomic>
#include <memory>
#include <thread>
#include <vector>

#include "config/config.hpp"
#include "daemon/runtime/notify.hpp"
#include "daemon/runtime/scheduler.hpp"
#include "daemon/runtime/supervisor.hpp"
#include "daemon/runtime/unit_pipeline.hpp"
#include "io/dds/participant.hpp"

namespace hvac_twin::runtime {

class Daemon {
 public:
  Daemon(config::Config config, std::shared_ptr<spdlog::logger> log, FaultHooks hooks = {});
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

  config::Config config_;
  std::shared_ptr<spdlog::logger> log_;
  FaultHooks hooks_;
  SystemdNotifier notifier_;
  std::unique_ptr<dds::Participant> participant_;
  std::vector<std::unique_ptr<UnitPipeline>> pipelines_;
  std::vector<std::unique_ptr<FixedRateScheduler>> schedulers_;
  std::unique_ptr<CycleSupervisor> supervisor_;
  std::vector<std::thread> threads_;
  bool running_ = false;
};

}  // namespace hvac_twin::runtime
