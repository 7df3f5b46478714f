#include "daemon/runtime/unit_pipeline.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "config/enum_names.hpp"
#include "daemon/estimation/ekf.hpp"
#include "daemon/estimation/enkf.hpp"
#include "daemon/runtime/clock.hpp"
#include "daemon/runtime/unit_model.hpp"
#include "io/modbus/poller.hpp"
#include "plant_models/core/settling.hpp"

namespace hvac_twin::runtime {
namespace {

dds::PointQuality wire_quality(modbus::PointQuality q) {
  switch (q) {
    case modbus::PointQuality::kNotYetRead:
      return dds::PointQuality::kNotYetRead;
    case modbus::PointQuality::kGood:
      return dds::PointQuality::kGood;
    case modbus::PointQuality::kStale:
      return dds::PointQuality::kStale;
    case modbus::PointQuality::kCommFail:
      return dds::PointQuality::kCommFail;
    case modbus::PointQuality::kDeviceException:
      return dds::PointQuality::kDeviceException;
    case modbus::PointQuality::kOutOfRange:
      return dds::PointQuality::kOutOfRange;
  }
  return dds::PointQuality::kNotYetRead;
}

config::Conversion must_convert(const std::string& from, const std::string& to,
                                const std::string& what) {
  const auto c = config::conversion(from, to);
  if (!c)
    throw std::invalid_argument(what + ": unit \"" + from + "\" does not convert to \"" + to +
                                "\"");
  return *c;
}

// A value in model units the filter may use: finite and inside the signal's physical range.
bool usable(double value, double min, double max) {
  return std::isfinite(value) && value >= min && value <= max;
}

double lookup(const std::map<std::string, double>& m, const std::string& key, double fallback) {
  const auto it = m.find(key);
  return it == m.end() ? fallback : it->second;
}

// The filter estimator.type selects, with the options the configuration sets.
std::unique_ptr<est::Estimator> make_filter(const plant::ContinuousModel& model,
                                            const config::EstimatorConfig& c,
                                            std::span<const double> process_noise,
                                            std::size_t measurements) {
  if (c.type == config::EstimatorType::kConstrainedEnkf) {
    est::EnkfOptions opt;
    opt.members = static_cast<std::size_t>(c.ensemble_members);
    opt.threads = static_cast<std::size_t>(c.threads);
    opt.nis_gate = c.nis_gate;
    opt.robust_threshold = c.robust_threshold;
    opt.max_consecutive_rejections = c.max_consecutive_rejections;
    return std::make_unique<est::ConstrainedEnkf>(model, process_noise, measurements, opt);
  }
  est::EkfOptions opt;
  opt.nis_gate = c.nis_gate;
  opt.robust_threshold = c.robust_threshold;
  opt.max_consecutive_rejections = c.max_consecutive_rejections;
  opt.constrained = c.type == config::EstimatorType::kConstrainedEkf;
  return std::make_unique<est::Ekf>(model, process_noise, measurements, opt);
}

}  // namespace

UnitIo live_io(const config::Config& config, std::size_t unit_index, dds::Participant& participant,
               std::shared_ptr<spdlog::logger> log) {
  const config::UnitConfig& unit = config.units.at(unit_index);
  const auto wall_period = std::chrono::nanoseconds(
      std::llround(unit.estimator.period_s / config.runtime.time_scale * 1e9));
  return UnitIo{.source =
                    [&unit, log] {
                      return std::make_unique<modbus::Poller>(
                          unit.modbus, unit.points,
                          [log, id = unit.id, host = unit.modbus.host,
                           port = unit.modbus.port](const modbus::Event& e) {
                            const bool bad = e.kind == modbus::EventKind::kDisconnected ||
                                             e.kind == modbus::EventKind::kConnectFailed;
                            log->log(bad ? spdlog::level::warn : spdlog::level::info,
                                     "unit {}: modbus {}:{}: {}", id, host, port, e.message);
                          });
                    },
                .sink =
                    [&config, &participant, &unit, wall_period](bool leak_diagnostic) {
                      return std::make_unique<dds::UnitPublisher>(
                          participant, config.dds.topic_prefix, config.site_id, unit.id,
                          wall_period, leak_diagnostic);
                    }};
}

UnitPipeline::UnitPipeline(const config::Config& config, std::size_t unit_index,
                           dds::Participant& participant, std::shared_ptr<spdlog::logger> log,
                           CycleHooks* hooks)
    : UnitPipeline(config, unit_index, live_io(config, unit_index, participant, log), log, hooks) {}

UnitPipeline::UnitPipeline(const config::Config& config, std::size_t unit_index, const UnitIo& io,
                           std::shared_ptr<spdlog::logger> log, CycleHooks* hooks)
    : unit_(config.units.at(unit_index)),
      site_(config.site_id),
      log_(std::move(log)),
      hooks_(hooks),
      period_s_(unit_.estimator.period_s),
      wall_period_ns_(static_cast<std::int64_t>(
          std::llround(unit_.estimator.period_s / config.runtime.time_scale * 1e9))),
      deadline_ns_(static_cast<std::int64_t>(std::llround(unit_.estimator.deadline_s * 1e9))) {
  UnitModel made = make_unit_model(unit_.model, config.state_directory + "/fmu/" + unit_.id,
                                   "/units/" + std::to_string(unit_index) + "/model");
  model_ = std::move(made.model);
  log_->info("unit {}: model {}", unit_.id, made.origin);
  const plant::ModelLayout& layout = model_->layout();
  phases_cold_ = std::make_unique<est::StatePhases>(layout, std::vector<est::KnownState>{},
                                                    unit_.estimator.parameter_hold_s, 0.0,
                                                    unit_.estimator.parameter_release_s);
  phases_resumed_ =
      std::make_unique<est::StatePhases>(layout, std::vector<est::KnownState>{}, 0.0, 0.0);
  phases_ramp_ = std::make_unique<est::StatePhases>(
      est::StatePhases::resumed_ramp(layout, unit_.estimator.parameter_release_s));
  phases_ = phases_cold_.get();

  // Initial state, its uncertainty and the process noise: model defaults, then configuration.
  std::vector<double> q;
  for (const auto& s : layout.states) {
    configured_x0_.push_back(unit_.estimator.initial_state.contains(s.name));
    x0_.push_back(lookup(unit_.estimator.initial_state, s.name, s.initial));
    std0_.push_back(lookup(unit_.estimator.initial_std, s.name, s.initial_std));
    q.push_back(lookup(unit_.estimator.process_noise, s.name, s.process_noise));
  }

  // Bind points to model inputs and outputs.
  for (std::size_t i = 0; i < layout.inputs.size(); ++i) {
    InputBinding b;
    b.input = i;
    b.min = layout.inputs[i].min;
    b.max = layout.inputs[i].max;
    b.value = layout.inputs[i].default_value;
    b.have = std::isfinite(b.value);
    for (std::size_t p = 0; p < unit_.points.size(); ++p) {
      const auto& pc = unit_.points[p];
      if (pc.role == config::PointRole::kMeasured || pc.signal != layout.inputs[i].name) continue;
      b.point = static_cast<long>(p);
      b.to_model = must_convert(pc.unit, layout.inputs[i].unit, "point " + pc.name);
    }
    if (b.point < 0 && !b.have)
      throw std::invalid_argument("model input " + layout.inputs[i].name + " has no point");
    inputs_.push_back(b);
  }
  for (std::size_t p = 0; p < unit_.points.size(); ++p) {
    const auto& pc = unit_.points[p];
    if (pc.role != config::PointRole::kMeasured) continue;
    const auto out = layout.output(pc.signal);
    if (!out) throw std::invalid_argument("point " + pc.name + ": unknown output " + pc.signal);
    MeasuredBinding b;
    b.point = p;
    b.output = *out;
    b.to_model = must_convert(pc.unit, layout.outputs[*out].unit, "point " + pc.name);
    b.min = layout.outputs[*out].min;
    b.max = layout.outputs[*out].max;
    const double sigma = lookup(unit_.estimator.measurement_noise, pc.signal, 0.0);
    if (!(sigma > 0.0)) throw std::invalid_argument("no measurement noise for " + pc.signal);
    b.variance = sigma * sigma;
    b.stuck = est::StuckMonitor(pc.stuck_after_s, est::kStuckMoveSigmas * sigma);
    measured_.push_back(b);
  }

  if (measured_.size() > 64)  // fused_points is a 64-bit mask on the wire
    throw std::invalid_argument("at most 64 measured points per unit");
  filter_ = make_filter(*model_, unit_.estimator, q, measured_.size());
  bind_leak_detection(unit_.estimator.leak_detection);
  bind_consistency();
  if (unit_.estimator.checkpoint_every_cycles > 0) open_checkpoints(config.state_directory);

  guess_x_.assign(layout.states.size(), 0.0);
  guess_y_.assign(layout.outputs.size(), 0.0);
  samples_.resize(unit_.points.size());
  u_.assign(layout.inputs.size(), 0.0);
  u_prev_ = u_;
  y_.assign(layout.outputs.size(), 0.0);
  sigma_ = filter_sigma_ = y_;
  // The unit_estimate sample: names and units bound once, values filled every cycle.
  for (std::size_t i = 0; i < layout.outputs.size() && i < dds::kMaxUnitEstimates; ++i)
    unit_estimate_.push_back({.name = layout.outputs[i].name, .eng_unit = layout.outputs[i].unit});
  if (layout.outputs.size() > dds::kMaxUnitEstimates)
    log_->warn(
        "unit {}: the model has {} outputs; unit_estimate carries the first {} "
        "(virtual_sensor all of them)",
        unit_.id, layout.outputs.size(), dds::kMaxUnitEstimates);
  z_.resize(measured_.size());
  reports_.resize(measured_.size());

  poller_ = io.source();
  publisher_ = io.sink(leak_ != nullptr);
  if (config.runtime.recording_budget_mib > 0) open_recording(config);
}

UnitPipeline::~UnitPipeline() {
  stop();
}

void UnitPipeline::start() {
  stopping_ = false;
  poller_->start();
}

void UnitPipeline::stop() {
  stopping_ = true;
  if (poller_) poller_->stop();
}

bool UnitPipeline::read_inputs(std::uint32_t& flags) {
  bool ready = true;
  for (auto& b : inputs_) {
    if (b.point >= 0) {
      const auto& s = samples_[static_cast<std::size_t>(b.point)];
      const double v = b.to_model.apply(s.value);
      const bool good = s.quality == modbus::PointQuality::kGood;
      const bool refused = good && !usable(v, b.min, b.max);
      if (good)
        note_refusal(b.refusing, refused, unit_.points[static_cast<std::size_t>(b.point)].name, v);
      if (good && !refused) {
        b.value = v;
        b.have = true;
      } else if (b.have) {
        flags |= dds::kFlagInputHeld;  // zero-order hold of the last good value
      }
      if (refused) ++guards_.inputs_refused;
    }
    if (!b.have) ready = false;
    u_[b.input] = b.value;
  }
  return ready;
}

void UnitPipeline::build_measurements() {
  for (std::size_t i = 0; i < measured_.size(); ++i) {
    auto& b = measured_[i];
    const auto& s = samples_[b.point];
    const double v = b.to_model.apply(s.value);
    const bool good = s.quality == modbus::PointQuality::kGood;
    const bool refused = good && !usable(v, b.min, b.max);
    if (good) note_refusal(b.refusing, refused, unit_.points[b.point].name, v);
    if (refused) ++guards_.measurements_refused;
    const est::StuckStep stuck = b.stuck.observe(good, s.value, b.drift, model_time_s_);
    note_stuck(stuck, unit_.points[b.point].name, s.value);
    z_[i] = est::Measurement{.output = b.output,
                             .value = refused ? 0.0 : v,
                             .variance = noise_ ? noise_->variance(i, b.variance) : b.variance,
                             .available = good && !refused && !stuck.stuck};
  }
}

// Logs the start and the end of a stuck episode of one point, not every cycle.
void UnitPipeline::note_stuck(const est::StuckStep& s, const std::string& point, double value) {
  if (s.started)
    log_->warn(
        "unit {}: point {}: STUCK: its value {} has not changed for {:.0f} model seconds while the "
        "model moved it by {:.3g} (model units); not used until it changes (stuck_after_s)",
        unit_.id, point, value, s.unchanged_s, s.moved);
  if (s.ended) log_->info("unit {}: point {}: no longer stuck", unit_.id, point);
}

// Logs the start and the end of a run of refused samples of one point, not every cycle.
void UnitPipeline::note_refusal(bool& refusing, bool refused, const std::string& point,
                                double value) {
  if (refused == refusing) return;
  refusing = refused;
  if (refused)
    log_->warn(
        "unit {}: point {}: value {} (model units) not finite or outside the model's "
        "range: not used",
        unit_.id, point, value);
  else
    log_->info("unit {}: point {}: values usable again", unit_.id, point);
}

// The first state: the configuration's initial values where it gives them, otherwise the
// model's own guess at the first inputs and measurements (or the layout's defaults), settled
// for estimator.settle_s model seconds at the first inputs; or the last checkpoint.
void UnitPipeline::initialize() {
  start_from_measurements(0.0);
  model_time_s_ = 0.0;
  initialized_ = true;
  have_prev_ = false;
  const Resumed resumed = checkpoints_ ? resume_from_checkpoint() : Resumed::kNo;
  if (resumed == Resumed::kNo) {
    cold_start_ = true;
    log_->info("unit {}: estimator started{}", unit_.id,
               guessed_ ? " from the model's guess at the measured conditions" : "");
  } else if (resumed == Resumed::kProperties) {
    // A cold start keeping the unit's properties: the settling hold from now (holding them).
    cold_start_ = true;
    converged_updates_ = 0;
    phases_from_s_ = model_time_s_;
    phases_->apply(*filter_, 0.0);
  } else {
    // A resumed filter has its parameters: no settling hold, only the excitation holds; if they
    // were not fully released when it was saved, the release ramp once more from now.
    cold_start_ = resumed == Resumed::kConverging;
    converged_updates_ = 0;
    phases_ = resumed_releasing_ ? phases_ramp_.get() : phases_resumed_.get();
    phases_from_s_ = model_time_s_;
    phases_->apply(*filter_, 0.0);
  }
}

void UnitPipeline::start_from_measurements(double model_time_s, const FilterSnapshot* keep) {
  std::fill(guess_y_.begin(), guess_y_.end(), std::numeric_limits<double>::quiet_NaN());
  for (const auto& b : measured_) {
    const auto& s = samples_[b.point];
    const double v = b.to_model.apply(s.value);
    if (s.quality == modbus::PointQuality::kGood && usable(v, b.min, b.max)) guess_y_[b.output] = v;
  }
  guessed_ = model_->initial_guess(u_, guess_y_, guess_x_);
  const auto& states = model_->layout().states;
  for (std::size_t i = 0; i < guess_x_.size(); ++i) {
    if (!guessed_ || configured_x0_[i]) guess_x_[i] = x0_[i];
    if (keep != nullptr && states[i].persistent) guess_x_[i] = keep->x[i];
  }
  if (unit_.estimator.settle_s > 0.0) {
    std::string error;
    if (!plant::settle(*model_, u_, unit_.estimator.settle_s, guess_x_, &error))
      log_->warn("unit {}: the model did not settle from its initial guess: {}", unit_.id, error);
  }
  // Bad-data guard: the filter never starts from a non-finite guess (a failed settle or guess).
  if (!std::all_of(guess_x_.begin(), guess_x_.end(), [](double v) { return std::isfinite(v); })) {
    log_->warn("unit {}: the initial guess is not finite; starting from the defaults", unit_.id);
    std::copy(x0_.begin(), x0_.end(), guess_x_.begin());
  }
  filter_->reset(guess_x_, std0_);
  if (noise_) noise_->discard_held();
  failed_predictions_ = 0;
  phases_from_s_ = model_time_s;
  phases_ = phases_cold_.get();
  phases_->apply(*filter_, 0.0);
  cold_start_ = true;  // converging again
  converged_updates_ = 0;
}

void UnitPipeline::step_convergence() {
  if (!cold_start_) return;
  bool agree = !phases_->settling(model_time_s_ - phases_from_s_);
  bool fused = false;
  for (const auto& r : reports_) {
    fused = fused || r.fused;
    if (r.available && !r.fused && !r.faulty) agree = false;
  }
  converged_updates_ = agree && fused ? converged_updates_ + 1 : 0;
  if (converged_updates_ < kConvergedAfterUpdates) return;
  cold_start_ = false;
  log_->info(
      "unit {}: the estimator has converged {:.0f} model seconds after its start (every point "
      "agreed with it {} updates in a row): flag cold_start cleared",
      unit_.id, model_time_s_ - phases_from_s_, kConvergedAfterUpdates);
}

void UnitPipeline::step_track(const est::TrackStep& s, std::uint32_t& flags) {
  if (s.lost) flags |= dds::kFlagLostTrack;
  if (s.episode_started)
    log_->warn(
        "unit {}: lost track: most measured points contradict the estimate ({} of {} gated out, "
        "{} updates in a row); estimates DEGRADED (flag lost_track) until they agree again",
        unit_.id, s.rejected, s.available, est::kLostAfterUpdates);
  if (s.first_reset)
    log_->warn(
        "unit {}: the filter reset its covariance to the initial one, state kept (most "
        "points gated out {} updates in a row, or one point long gated out is plausible "
        "again); {} covariance resets since start-up",
        unit_.id, unit_.estimator.max_consecutive_rejections,
        filter_->counters().covariance_resets);
  if (s.restart_due) {
    ++restarts_;
    if (s.first_restart)
      log_->warn(
          "unit {}: still lost after {} updates; the estimator restarts from the measured "
          "conditions (restart {} since start-up)",
          unit_.id, est::kRestartAfterLostUpdates, restarts_);
    start_from_measurements(model_time_s_);
    flags |= dds::kFlagNumericalReset;
  }
  if (s.episode_ended) {
    const auto& e = track_.last_episode();
    log_->info(
        "unit {}: back on track after {} updates with most points gated out ({} covariance "
        "resets, {} restarts)",
        unit_.id, e.updates, e.covariance_resets, e.restarts);
  }
}

CycleOutcome UnitPipeline::run_cycle(const Tick& tick) {
  const std::int64_t start = monotonic_ns();
  const std::int64_t stamp = tick.wall_ns != 0 ? tick.wall_ns : realtime_ns();
  poller_->snapshot(samples_, start, &device_);
  if (recorder_)
    recorder_->submit(tick.index, tick.ticks_since_last, stamp, device_.connected, samples_, start);
  CycleOutcome out;
  std::uint32_t flags = 0;
  const bool inputs_ready = read_inputs(flags);

  if (!initialized_ && inputs_ready) initialize();
  if (initialized_) {
    out.ran_estimator = true;
    if (have_prev_) {
      // dt from the tick stamps: skipped ticks advance the model by more than one period.
      const double dt = period_s_ * static_cast<double>(tick.ticks_since_last);
      // With the inputs of the period ahead: parameters its process does not excite are held.
      phases_->apply(*filter_, model_time_s_ - phases_from_s_, u_prev_);
      const est::StepStatus st = filter_->predict(u_prev_, dt);
      if (st == est::StepStatus::kNumericalReset) flags |= dds::kFlagNumericalReset;
      if (st == est::StepStatus::kModelError) flags |= dds::kFlagPredictOnly;
      model_time_s_ += dt;
      failed_predictions_ = st == est::StepStatus::kModelError ? failed_predictions_ + 1 : 0;
      const char* model_failure = model_->failure();
      if (model_failure != nullptr && !model_failed_) {
        // A model that failed for good (an FMU's fmi2Error): no restart brings it back. The
        // unit keeps cycling (its points, health and the other units go on); its estimates are
        // NOT_READY from now on.
        model_failed_ = true;
        log_->error(
            "unit {}: the model failed for good: {}; the unit publishes no estimates until the "
            "daemon restarts",
            unit_.id, model_failure);
      }
      if (failed_predictions_ >= kRestartAfterFailedPredictions && !model_failed_) {
        // Lost: the model cannot integrate from the estimate (kept by every failed prediction),
        // and no update brought it back. Start again from the measured conditions.
        ++restarts_;
        log_->warn(
            "unit {}: {} predictions in a row failed; the estimator restarts from the measured "
            "conditions (restart {} since start-up)",
            unit_.id, failed_predictions_, restarts_);
        start_from_measurements(model_time_s_);
        flags |= dds::kFlagNumericalReset;
      }
    }
    if (hooks_ != nullptr) hooks_->after_predict(unit_.id, tick.index, stopping_);
    fused_points_ = 0;
    // A late cycle still fuses its measurements. The update costs under 1 % of the step
    // (estimation_bench); skipping it once the prediction had used up the deadline left a
    // unit on a loaded gateway running on its model alone, its leak detector held, for as long
    // as the load lasted. Lateness is flagged at the end of the cycle (deadline overrun).
    build_measurements();
    const std::uint64_t resets_before = filter_->counters().covariance_resets;
    const est::StepStatus st = filter_->update(z_, u_, reports_);
    // What the model alone did to every measured point over the period (the stuck check).
    for (std::size_t i = 0; i < reports_.size(); ++i)
      measured_[i].drift = st == est::StepStatus::kModelError
                               ? std::numeric_limits<double>::quiet_NaN()
                               : reports_[i].predicted - measured_[i].estimate;
    if (st == est::StepStatus::kNumericalReset) flags |= dds::kFlagNumericalReset;
    const bool covariance_reset = filter_->counters().covariance_resets != resets_before;
    if (covariance_reset) flags |= dds::kFlagNumericalReset;
    const est::TrackStep track = track_.observe(reports_, covariance_reset);
    step_track(track, flags);
    // A lost filter's innovations measure its own error, not the sensors' noise: neither this
    // update nor the ones held before it (the loss is declared some updates late) are learnt.
    if (noise_ && (track.lost || covariance_reset || track.restart_due))
      noise_->discard_held();
    else if (noise_)
      noise_->observe(z_, reports_, told_variance_);
    for (std::size_t i = 0; i < reports_.size(); ++i)
      if (reports_[i].fused) fused_points_ |= std::uint64_t{1} << i;
    if (!filter_->active_constraints().empty()) flags |= dds::kFlagConstraintActive;
    step_consistency();
    step_convergence();
    if (fused_points_ == 0) flags |= dds::kFlagPredictOnly;
    u_prev_ = u_;
    have_prev_ = true;
  }

  if (initialized_ && cold_start_) flags |= dds::kFlagColdStart;  // after a restart this cycle too
  const bool estimates_valid =
      initialized_ && filter_->output_estimates(u_, y_, sigma_, filter_sigma_) == plant::kModelOk;
  for (auto& b : measured_)
    b.estimate = estimates_valid ? y_[b.output] : std::numeric_limits<double>::quiet_NaN();
  if (monotonic_ns() - start > deadline_ns_) flags |= dds::kFlagDeadlineOverrun;
  // What makes an estimate worse than GOOD: no data fused, a held input, a reset, lost track.
  // A late one (deadline overrun) is published DEGRADED too, so a reader knows it was late, but it
  // is as good as any: the leak detector judges it.
  constexpr std::uint32_t kWorse =
      dds::kFlagPredictOnly | dds::kFlagInputHeld | dds::kFlagNumericalReset | dds::kFlagLostTrack;
  out.quality = !estimates_valid                               ? dds::EstimateQuality::kNotReady
                : flags & (kWorse | dds::kFlagDeadlineOverrun) ? dds::EstimateQuality::kDegraded
                                                               : dds::EstimateQuality::kGood;
  if (out.quality == dds::EstimateQuality::kDegraded) ++degraded_cycles_;
  out.flags = flags;
  note_quality(out.quality, flags);
  publish(stamp, tick.index, out.quality, flags, estimates_valid);
  publish_consistency(stamp, tick.index);
  if (leak_) {
    step_leak_detector((flags & kWorse) != 0, estimates_valid);
    publish_leak(stamp, tick.index, out.quality, estimates_valid);
  }

  const std::int64_t end = monotonic_ns();
  out.cycle_ns = end - start;
  out.overrun = out.cycle_ns > deadline_ns_;
  if (out.overrun) ++overruns_;
  cycle_ns_ = out.cycle_ns;
  if (out.cycle_ns > cycle_max_ns_) cycle_max_ns_ = out.cycle_ns;
  publish_health(stamp, tick.index, out.quality);
  last_stamp_ns_ = stamp;  // for the save on a clean stop (save_final_checkpoint)
  last_cycle_ = tick.index;
  // Hands the snapshot to the checkpoint writer thread: the disk never delays a cycle.
  if (checkpoints_ && initialized_ &&
      ++cycles_since_checkpoint_ >=
          static_cast<std::uint64_t>(unit_.estimator.checkpoint_every_cycles)) {
    cycles_since_checkpoint_ = 0;
    save_checkpoint(stamp, tick.index);
  }
  return out;
}

void UnitPipeline::open_recording(const config::Config& config) {
  recording::RecordingHeader h{.site = site_,
                               .unit = unit_.id,
                               .model = unit_.model.type,
                               .period_s = period_s_,
                               .run_ns = realtime_ns()};
  for (const auto& p : unit_.points)
    h.points.push_back({p.name, p.unit, std::string(config::to_string(p.role))});
  const auto budget = static_cast<std::uint64_t>(config.runtime.recording_budget_mib) << 20;
  recorder_ = std::make_unique<recording::Recorder>(config.state_directory + "/recordings",
                                                    std::move(h), budget, log_);
  log_->info("unit {}: recording every cycle in {} (at most {} MiB)", unit_.id,
             recorder_->directory(), config.runtime.recording_budget_mib);
}

void UnitPipeline::publish(std::int64_t stamp_ns, std::uint64_t cycle, dds::EstimateQuality quality,
                           std::uint32_t flags, bool estimates_valid) {
  const plant::ModelLayout& layout = model_->layout();
  if (estimates_valid) {
    for (std::size_t i = 0; i < y_.size(); ++i) {
      const bool poison = i == 0 && hooks_ != nullptr && hooks_->poison_output(cycle);
      publisher_->publish(dds::VirtualSensorSample{.name = layout.outputs[i].name,
                                                   .value = poison ? std::nan("") : y_[i],
                                                   .sigma = sigma_[i],
                                                   .eng_unit = layout.outputs[i].unit,
                                                   .quality = quality,
                                                   .flags = flags,
                                                   .fused_points = fused_points_,
                                                   .timestamp_ns = stamp_ns,
                                                   .cycle = cycle});
    }
    for (std::size_t i = 0; i < unit_estimate_.size(); ++i) {
      unit_estimate_[i].value = y_[i];
      unit_estimate_[i].sigma = sigma_[i];
    }
    publisher_->publish(dds::UnitEstimateSample{.estimates = unit_estimate_,
                                                .quality = quality,
                                                .flags = flags,
                                                .fused_points = fused_points_,
                                                .timestamp_ns = stamp_ns,
                                                .cycle = cycle});
  }
  for (std::size_t i = 0; i < measured_.size(); ++i) {
    const auto& b = measured_[i];
    const auto& s = samples_[b.point];
    const auto& r = reports_[i];
    // Reported in the point's own unit: invert the affine conversion to the model's unit.
    const double scale = b.to_model.scale;
    const double predicted = (r.predicted - b.to_model.offset) / scale;
    const bool tested = r.available && initialized_;
    publisher_->publish(dds::ObservationSample{
        .point = unit_.points[b.point].name,
        .value = s.value,
        .quality = b.stuck.stuck() ? dds::PointQuality::kStuck : wire_quality(s.quality),
        .exception_code = s.exception_code,
        .predicted = tested ? predicted : 0.0,
        .innovation = tested ? s.value - predicted : 0.0,
        .innovation_variance = tested ? r.innovation_variance / (scale * scale) : 0.0,
        .test_ratio = tested ? r.test_ratio : 0.0,
        .fused = r.fused,
        .timestamp_ns = stamp_ns,
        .cycle = cycle});
  }
  if (!estimates_valid || measured_.empty()) publisher_->assert_liveliness();
}

void UnitPipeline::publish_health(std::int64_t stamp_ns, std::uint64_t cycle,
                                  dds::EstimateQuality quality) {
  const auto& c = filter_->counters();
  publisher_->publish(
      dds::HealthSample{.cycle = cycle,
                        .cycle_time_ms = static_cast<double>(cycle_ns_) * 1e-6,
                        .cycle_time_max_ms = static_cast<double>(cycle_max_ns_) * 1e-6,
                        .overruns = overruns_,
                        .degraded_cycles = degraded_cycles_,
                        .gate_rejections = c.gate_rejections,
                        .numerical_resets = c.numerical_resets + c.covariance_resets,
                        .quality = quality,
                        .modbus_connected = device_.connected,
                        .modbus_polls_ok = device_.polls_ok,
                        .modbus_polls_exception = device_.polls_exception,
                        .modbus_polls_failed = device_.polls_failed,
                        .modbus_reconnects = device_.reconnects,
                        .modbus_last_error = device_.last_error,
                        .timestamp_ns = stamp_ns});
}

void UnitPipeline::note_quality(dds::EstimateQuality quality, std::uint32_t flags) {
  if (quality == last_quality_ && flags == last_flags_) return;
  if (quality != last_quality_) {
    const auto level =
        quality == dds::EstimateQuality::kGood ? spdlog::level::info : spdlog::level::warn;
    log_->log(level, "unit {}: estimates {} (flags 0x{:02x})", unit_.id, dds::to_string(quality),
              flags);
  }
  last_quality_ = quality;
  last_flags_ = flags & ~dds::kFlagColdStart;
}

}  // namespace hvac_twin::runtime
