#include "daemon/runtime/daemon.hpp"

#include <spdlog/fmt/fmt.h>
#include <unistd.h>

#include <algorithm>
#include <string>

#include "config/enum_names.hpp"
#include "daemon/runtime/clock.hpp"
#include "io/dds/security.hpp"

namespace hvac_twin::runtime {

Daemon::Daemon(config::Config config, std::shared_ptr<spdlog::logger> log, CycleHooks* hooks)
    : config_(std::move(config)), log_(std::move(log)), hooks_(hooks) {}

Daemon::~Daemon() {
  stop();
}

void Daemon::start() {
  participant_ = dds::make_participant(config_.dds);
  log_->info("DDS domain {} on interface {}, topics {}/*, DDS Security {}", config_.dds.domain_id,
             config_.dds.interface, config_.dds.topic_prefix,
             config_.dds.security ? "on (governance " + config_.dds.security->governance + ")"
                                  : std::string("off"));
  for (std::size_t i = 0; i < config_.units.size(); ++i) {
    pipelines_.push_back(std::make_unique<UnitPipeline>(config_, i, *participant_, log_, hooks_));
    const auto& u = config_.units[i];
    const std::string members = u.estimator.type == config::EstimatorType::kConstrainedEnkf
                                    ? fmt::format(" ({} members, {} threads)",
                                                  u.estimator.ensemble_members, u.estimator.threads)
                                    : std::string();
    log_->info(
        "unit {}: model {} ({} states), filter {}{}, {} points from {}:{} unit {}, period {} s "
        "(wall {:.3f} s), deadline {} s{}",
        u.id, u.model.type, pipelines_.back()->filter().num_states(),
        config::to_string(u.estimator.type), members, u.points.size(), u.modbus.host, u.modbus.port,
        u.modbus.unit_id, u.estimator.period_s,
        static_cast<double>(pipelines_.back()->wall_period_ns()) * 1e-9, u.estimator.deadline_s,
        pipelines_.back()->leak_detector() ? ", leak detection on" : "");
  }

  SupervisorOptions sup;
  sup.hang_timeout_ns = static_cast<std::int64_t>(config_.runtime.hang_timeout_s * 1e9);
  sup.hang_exit = config_.runtime.hang_exit;
  sup.overrun_limit = config_.runtime.overruns_before_watchdog_stop;
  // Rate-limited to an eighth of WatchdogSec, so the gap between pings stays below
  // WatchdogSec / 8 + one cycle period.
  sup.min_ping_interval_ns = notifier_.watchdog_interval_ns() / 8;
  for (const auto& p : pipelines_) {
    if (notifier_.watchdog_interval_ns() > 0 &&
        p->wall_period_ns() > notifier_.watchdog_interval_ns() / 2)
      log_->warn(
          "unit {}: cycle period {:.3f} s is longer than half of WatchdogSec ({:.3f} s): "
          "systemd will consider the service hung",
          p->id(), static_cast<double>(p->wall_period_ns()) * 1e-9,
          static_cast<double>(notifier_.watchdog_interval_ns()) * 1e-9);
  }
  supervisor_ = std::make_unique<CycleSupervisor>(
      pipelines_.size(), notifier_, sup,
      [this](std::size_t unit, std::int64_t running_ns) {
        log_->critical("unit {}: cycle hung for {:.1f} s{}", pipelines_[unit]->id(),
                       static_cast<double>(running_ns) * 1e-9,
                       config_.runtime.hang_exit ? "; exiting so the service is restarted" : "");
        log_->flush();
      },
      [this](const PingChange& c) { log_ping_change(c); });
  supervisor_->start();

  const std::int64_t start = monotonic_ns();
  const auto units = static_cast<std::int64_t>(pipelines_.size());
  for (std::size_t i = 0; i < pipelines_.size(); ++i) {
    pipelines_[i]->start();
    // The first cycle one wall period after start: the poller has read every point by then.
    // Unit i of n is then due i/n of its period later: cycles that fall due at one instant
    // queue behind each other on a core, so with the ticks aligned the last of n units finished
    // n cycle times after its tick (scale_bench, 10 heat pumps on one core: 102 ms median for
    // 12 ms of work each) and a gateway that had the CPU for all of them still missed deadlines.
    const std::int64_t period = pipelines_[i]->wall_period_ns();
    const std::int64_t phase = period / units * static_cast<std::int64_t>(i);
    schedulers_.push_back(std::make_unique<FixedRateScheduler>(start + period + phase, period));
  }
  for (std::size_t i = 0; i < pipelines_.size(); ++i)
    threads_.emplace_back([this, i] { run_unit(i); });
  running_ = true;
  notifier_.ready();
  notifier_.status("running " + std::to_string(pipelines_.size()) + " unit(s)");
  log_->info("hvac-twind running: site {}, {} unit(s)", config_.site_id, pipelines_.size());
}

void Daemon::run_unit(std::size_t index) {
  UnitPipeline& pipeline = *pipelines_[index];
  FixedRateScheduler& scheduler = *schedulers_[index];
  RepeatLog overruns(kRepeatLogIntervalNs);
  supervisor_->attach_thread(index, ::gettid());
  Tick tick;
  while (scheduler.wait_next(tick)) {
    supervisor_->cycle_started(index, tick.woke_ns);
    const CycleOutcome out = pipeline.run_cycle(tick);
    const std::int64_t now = monotonic_ns();
    log_overruns(pipeline.id(), tick.index,
                 overruns.observe(out.overrun, static_cast<double>(out.cycle_ns) * 1e-6, now));
    supervisor_->cycle_finished(index, now, out.overrun);
  }
}

void Daemon::log_overruns(const std::string& unit, std::uint64_t cycle, const RepeatStep& s) const {
  constexpr double interval_s = static_cast<double>(kRepeatLogIntervalNs) * 1e-9;
  if (s.start)
    log_->warn(
        "unit {}: cycle {} overran its deadline: {:.1f} ms (further overruns are counted, one "
        "line per {:.0f} s, until none for {:.0f} s)",
        unit, cycle, s.worst, interval_s, interval_s);
  else if (s.summary)
    log_->warn("unit {}: {} more cycles overran their deadline (worst {:.1f} ms); {} so far", unit,
               s.count, s.worst, s.total);
  else if (s.end)
    log_->info("unit {}: no cycle overran its deadline for {:.0f} s ({} overruns in the episode)",
               unit, interval_s, s.total);
}

void Daemon::log_ping_change(const PingChange& c) const {
  const auto& unit = pipelines_[c.unit]->id();
  if (c.stopped) {
    const std::int64_t watchdog_ns = notifier_.watchdog_interval_ns();
    const std::string consequence =
        watchdog_ns > 0
            ? fmt::format("systemd restarts the service if this lasts WatchdogSec ({:.3f} s)",
                          static_cast<double>(watchdog_ns) * 1e-9)
            : std::string("no systemd watchdog is configured, so nothing restarts it");
    log_->warn(
        "watchdog pings stopped: unit {} overran its deadline {} cycles in a row "
        "(runtime.overruns_before_watchdog_stop {}); {}",
        unit, c.consecutive_overruns, config_.runtime.overruns_before_watchdog_stop, consequence);
  } else {
    log_->info(
        "watchdog pings resumed: unit {} completed a cycle within its deadline after {} "
        "overruns in a row; pings were withheld for {:.1f} s",
        unit, c.consecutive_overruns, static_cast<double>(c.withheld_ns) * 1e-9);
  }
}

void Daemon::stop() {
  if (!running_ && threads_.empty()) return;
  notifier_.stopping();
  for (auto& s : schedulers_)
    s->stop();
  for (auto& p : pipelines_)
    p->stop();  // also releases a cycle held by a fault hook
  for (auto& t : threads_)
    if (t.joinable()) t.join();
  threads_.clear();
  for (auto& p : pipelines_)
    p->save_final_checkpoint();  // written as the pipelines are destroyed below
  if (supervisor_) supervisor_->stop();
  pipelines_.clear();
  participant_.reset();
  running_ = false;
  log_->info("hvac-twind stopped");
}

}  // namespace hvac_twin::runtime
