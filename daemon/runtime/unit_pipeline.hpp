// One unit's estimator cycle: Modbus snapshot -> inputs -> predict -> (deadline check) -> gated
// (constrained) update -> consistency monitor -> virtual sensors with delta-method sigma -> leak
// detector -> DDS samples.
// The filter is the one the configuration selects (estimator.type) behind est::Estimator.
//
// Everything is built and sized in the constructor (start-up: allocates, throws on a bad model
// or a DDS/Modbus set-up failure); run_cycle() never allocates and never throws.
// Threads: the constructor, start() and stop() on the owner thread; run_cycle() on the unit's
// cycle thread only; checkpoints are written by a CheckpointWriter thread of their own.
#pragma once

#include <spdlog/logger.h>

#include <atomic>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "config/config.hpp"
#include "config/units.hpp"
#include "daemon/estimation/commissioning.hpp"
#include "daemon/estimation/consistency_monitor.hpp"
#include "daemon/estimation/estimator.hpp"
#include "daemon/estimation/leak_detector.hpp"
#include "daemon/estimation/noise_adapter.hpp"
#include "daemon/estimation/stuck_monitor.hpp"
#include "daemon/estimation/track_monitor.hpp"
#include "daemon/recording/recorder.hpp"
#include "daemon/runtime/checkpoint_store.hpp"
#include "daemon/runtime/checkpoint_writer.hpp"
#include "daemon/runtime/cycle_hooks.hpp"
#include "daemon/runtime/scheduler.hpp"
#include "io/dds/participant.hpp"
#include "io/dds/publisher.hpp"
#include "io/dds/unit_sink.hpp"
#include "io/modbus/point_source.hpp"
#include "plant_models/core/integrator.hpp"
#include "plant_models/core/model.hpp"

namespace hvac_twin::runtime {

// Bad-data guards between the poller and the filter. The poller already refuses values that are
// not finite or outside the point's configured range (OUT_OF_RANGE); the pipeline checks again
// after the conversion to model units, against the model signal's physical range (a point's
// configured range may be wider, and a conversion may overflow). A refused input holds its last
// good value (flag "input held"); a refused measurement is not offered to the filter.
struct GuardCounters {
  std::uint64_t inputs_refused = 0;        // GOOD input samples refused, one per cycle and input
  std::uint64_t measurements_refused = 0;  // GOOD measured samples refused, per cycle and point
};

struct CycleOutcome {
  bool overrun = false;
  bool ran_estimator = false;  // false while waiting for the first inputs
  dds::EstimateQuality quality = dds::EstimateQuality::kNotReady;
  std::uint32_t flags = 0;  // the dds::kFlag* bits published with the cycle's estimates
  std::int64_t cycle_ns = 0;
};

// Where a pipeline reads its points and writes its samples, made by the constructor once the
// model is built. The daemon's: the Modbus Poller and the DDS UnitPublisher (live_io()); the
// replay's: a recording and a CSV writer.
struct UnitIo {
  std::function<std::unique_ptr<modbus::PointSource>()> source;
  // leak_diagnostic: the unit's model estimates a leak rate (leak_diagnostic samples follow).
  std::function<std::unique_ptr<dds::UnitSink>(bool leak_diagnostic)> sink;
};
// The daemon's: a Modbus Poller of the unit's device logging its events, and DDS writers.
UnitIo live_io(const config::Config& config, std::size_t unit_index, dds::Participant& participant,
               std::shared_ptr<spdlog::logger> log);

class UnitPipeline {
 public:
  UnitPipeline(const config::Config& config, std::size_t unit_index, dds::Participant& participant,
               std::shared_ptr<spdlog::logger> log, CycleHooks* hooks = nullptr);
  UnitPipeline(const config::Config& config, std::size_t unit_index, const UnitIo& io,
               std::shared_ptr<spdlog::logger> log, CycleHooks* hooks = nullptr);
  ~UnitPipeline();
  UnitPipeline(const UnitPipeline&) = delete;
  UnitPipeline& operator=(const UnitPipeline&) = delete;

  void start();  // starts the Modbus poller
  void stop();   // stops the poller and releases a cycle blocked in a fault hook

  CycleOutcome run_cycle(const Tick& tick);

  // Owner thread, once the cycle thread has stopped: hands the last cycle's state to the
  // checkpoint writer unless the periodic checkpoint already holds it, so that a clean stop
  // (an upgrade, a reboot) keeps the newest state rather than one up to
  // estimator.checkpoint_every_cycles - 1 cycles older. Saved before the writer is destroyed.
  void save_final_checkpoint();

  [[nodiscard]] const std::string& id() const { return unit_.id; }
  [[nodiscard]] std::int64_t wall_period_ns() const { return wall_period_ns_; }
  [[nodiscard]] const est::Estimator& filter() const { return *filter_; }
  [[nodiscard]] const plant::ContinuousModel& model() const { return *model_; }
  // The model inputs of the last cycle's estimates [model units].
  [[nodiscard]] std::span<const double> inputs() const { return u_; }
  // The leak detector, or nullptr when the unit's model does not estimate a leak rate.
  [[nodiscard]] const est::LeakDetector* leak_detector() const { return leak_.get(); }
  [[nodiscard]] bool cold_start() const { return cold_start_; }          // converging; cycle thread
  [[nodiscard]] const GuardCounters& guards() const { return guards_; }  // cycle thread
  [[nodiscard]] dds::PublisherStats publisher_stats() const { return publisher_->stats(); }

 private:
  struct InputBinding {
    std::size_t input = 0;  // model input index
    long point = -1;        // point index, -1: the model default feeds it
    config::Conversion to_model;
    double min = 0.0, max = 0.0;  // the model input's physical range [model unit]
    double value = 0.0;           // last good value [model unit]
    bool have = false;
    bool refusing = false;  // the last GOOD sample was refused (logged once per episode)
  };
  struct MeasuredBinding {
    std::size_t point = 0;
    std::size_t output = 0;
    config::Conversion to_model;
    double min = 0.0, max = 0.0;  // the model output's physical range [model unit]
    double variance = 0.0;        // [model unit²]
    bool refusing = false;
    est::StuckMonitor stuck;  // a raw value frozen while the model moves (logged per episode)
    // The model's change of the point over the last period: the prior prediction at the last
    // update minus the estimate of the cycle before (NaN: unknown) [model unit].
    double drift = std::numeric_limits<double>::quiet_NaN();
    double estimate = std::numeric_limits<double>::quiet_NaN();  // last published [model unit]
  };

  bool read_inputs(std::uint32_t& flags);
  void build_measurements();
  void note_refusal(bool& refusing, bool refused, const std::string& point, double value);
  void note_stuck(const est::StuckStep& s, const std::string& point, double value);
  void publish(std::int64_t stamp_ns, std::uint64_t cycle, dds::EstimateQuality quality,
               std::uint32_t flags, bool estimates_valid);
  void bind_leak_detection(const config::LeakDetectionConfig& c);
  void open_checkpoints(const std::string& state_directory);
  enum class Resumed : std::uint8_t {
    kNo,          // cold start (the reason logged)
    kWhole,       // the whole filter state
    kConverging,  // the whole filter state, saved while still converging
    kProperties,  // too old: the unit's properties only, the rest re-settled (converging)
  };
  Resumed resume_from_checkpoint();
  // Keeps the cold start's state and covariance but for the model's persistent states.
  bool resume_properties(const FilterSnapshot& s);
  void save_checkpoint(std::int64_t stamp_ns, std::uint64_t cycle);
  // degraded: the estimates are worse than GOOD for a reason other than lateness.
  void step_leak_detector(bool degraded, bool estimates_valid);
  // The leak detector's state and learnt reference charges, for the log.
  [[nodiscard]] std::string describe_leak_detector() const;
  void publish_leak(std::int64_t stamp_ns, std::uint64_t cycle, dds::EstimateQuality quality,
                    bool estimates_valid);
  void publish_health(std::int64_t stamp_ns, std::uint64_t cycle, dds::EstimateQuality quality);
  void bind_consistency();
  void step_consistency();  // after update() filled reports_
  void note_consistency(std::size_t figure);
  void publish_consistency(std::int64_t stamp_ns, std::uint64_t cycle);
  void note_quality(dds::EstimateQuality quality, std::uint32_t flags);
  // Lost track (est::TrackMonitor): the flag on this cycle's samples, a log line per episode, and
  // the restart when the filter's own covariance resets did not bring it back.
  void step_track(const est::TrackStep& s, std::uint32_t& flags);

  config::UnitConfig unit_;
  std::string site_;
  std::shared_ptr<spdlog::logger> log_;
  CycleHooks* hooks_;            // null but in fault-injection tests
  double period_s_;              // model seconds per tick
  std::int64_t wall_period_ns_;  // wall nanoseconds per tick
  std::int64_t deadline_ns_;

  std::unique_ptr<plant::ContinuousModel> model_;
  std::unique_ptr<est::Estimator> filter_;
  std::unique_ptr<modbus::PointSource> poller_;
  std::unique_ptr<dds::UnitSink> publisher_;

  void initialize();
  // The filter from the model's guess at the current measured conditions (the first cycle, and
  // a filter whose predictions kept failing), with the augmented states held for
  // estimator.parameter_hold_s from `model_time_s`.
  // `keep`: a checkpoint whose persistent states the guess takes (settled with them).
  void start_from_measurements(double model_time_s, const FilterSnapshot* keep = nullptr);

  std::vector<double> x0_, std0_;
  std::vector<bool> configured_x0_;  // initial_state given by the configuration (kept as is)
  std::vector<double> guess_x_, guess_y_;
  std::vector<InputBinding> inputs_;
  std::vector<MeasuredBinding> measured_;
  std::vector<modbus::PointSample> samples_;
  modbus::DeviceStatus device_{};
  std::vector<double> u_, u_prev_, y_, sigma_;
  std::vector<double> filter_sigma_;  // sigma_ without the model's structural error (leak detector)
  std::vector<dds::EstimateEntry> unit_estimate_;  // y_ and sigma_ as one sample, names bound
  std::vector<est::Measurement> z_;
  std::vector<est::MeasurementReport> reports_;

  std::uint64_t fused_points_ = 0;  // bit i: measured_[i] fused this cycle

  // Leak detection (models with an augmented leak_rate state, a charge output and a compressor
  // speed input).
  std::unique_ptr<est::LeakDetector> leak_;
  std::size_t leak_output_ = 0, charge_output_ = 0, speed_input_ = 0;
  double nameplate_charge_ = 0.0;  // [kg], the charge state's initial value
  double false_alarm_days_ = 0.0;  // designed, published with every diagnostic
  double model_time_s_ = 0.0;      // model time since the filter started [s]
  // Augmented states held (considered) after a cold start, and parameters while their process
  // stands still (est::StatePhases).
  // Both built with the pipeline (a restart allocates nothing): after a start from the measured
  // conditions with the settling hold, after a resume without it; phases_ is the one in use.
  // phases_ramp_: after a resume from a checkpoint saved before the release was complete
  // (kSnapshotReleasing), the release ramp again from the resume, so that a restart mid-ramp
  // does not release the parameters at once.
  std::unique_ptr<est::StatePhases> phases_cold_, phases_resumed_, phases_ramp_;
  bool resumed_releasing_ = false;  // the checkpoint resumed from had kSnapshotReleasing
  const est::StatePhases* phases_ = nullptr;
  double phases_from_s_ = 0.0;  // the model time the phases count from [s]
  int failed_predictions_ = 0;  // in a row
  bool model_failed_ = false;   // the model said it cannot be evaluated again (failure())
  // A filter whose predictions failed this many cycles in a row is lost (each failure keeps the
  // estimate the model cannot integrate from) and restarts from the measured conditions. Seen
  // on the heat pump before the parameter hold: 40 failed cycles in a row from the third.
  static constexpr int kRestartAfterFailedPredictions = 6;
  // A filter that has lost track (est::TrackMonitor) est::kRestartAfterLostUpdates updates in a
  // row, through the EKF's covariance resets, restarts from the measured conditions; the EnKF,
  // which does not reset itself, likewise.
  est::TrackMonitor track_{est::kLostAfterUpdates, est::kRestartAfterLostUpdates};
  bool guessed_ = false;               // the last start used the model's own initial guess
  std::uint64_t restarts_ = 0;         // from the measured conditions, since start-up
  std::int64_t suspect_since_ns_ = 0;  // wall time the current SUSPECT/LEAK episode began
  std::int64_t leak_since_ns_ = 0;     // wall time of the first LEAK in this episode
  est::LeakState last_leak_state_ = est::LeakState::kNormal;  // the last one logged
  bool references_logged_ = false;  // the learnt reference charges were logged

  // Filter consistency: the mean NIS per measured point (figures 0..m-1) and over all (figure m)
  // over a window, and per figure its logged "high" episode.
  struct ConsistencyEpisode {
    bool high = false;            // in a logged HIGH episode
    std::size_t calm_cycles = 0;  // cycles in band or low since the last HIGH one
  };
  std::unique_ptr<est::ConsistencyMonitor> consistency_;
  // Adaptive measurement noise (estimator.adaptive_noise_*), null when off; the told variances,
  // and the reports as the consistency monitor judges them (against the told noise).
  std::unique_ptr<est::NoiseAdapter> noise_;
  std::vector<double> told_variance_;
  std::vector<est::MeasurementReport> told_reports_;
  std::vector<ConsistencyEpisode> consistency_episodes_;

  // Crash-safe checkpoints (estimator.checkpoint_every_cycles > 0).
  std::unique_ptr<CheckpointStore> checkpoints_;
  FilterSnapshot snapshot_;  // sized once; refilled in place before every save
  std::unique_ptr<CheckpointWriter> checkpoint_writer_;  // after the store: stopped before it
  std::uint64_t cycles_since_checkpoint_ = 0;
  std::int64_t last_stamp_ns_ = 0;  // the last cycle's stamp and index, whatever its outcome
  std::uint64_t last_cycle_ = 0;

  // The recording of every cycle's snapshot (runtime.recording_budget_mib > 0), null when off.
  std::unique_ptr<recording::Recorder> recorder_;
  void open_recording(const config::Config& config);
  // Flag cold_start: the filter started (or restarted) from the measured conditions and has not
  // converged yet. Cleared once the settling hold is over and every available point was fused
  // (or is a reported fault) kConvergedAfterUpdates updates in a row. A resume from a
  // checkpoint keeps what was saved (kSnapshotConverging).
  bool cold_start_ = true;
  int converged_updates_ = 0;  // in a row
  static constexpr int kConvergedAfterUpdates = 12;
  void step_convergence();

  bool initialized_ = false;
  bool have_prev_ = false;
  std::atomic<bool> stopping_{false};
  GuardCounters guards_;
  std::uint64_t overruns_ = 0;
  std::uint64_t degraded_cycles_ = 0;
  std::int64_t cycle_ns_ = 0;
  std::int64_t cycle_max_ns_ = 0;
  dds::EstimateQuality last_quality_ = dds::EstimateQuality::kNotReady;
  std::uint32_t last_flags_ = 0;
};

}  // namespace hvac_twin::runtime
