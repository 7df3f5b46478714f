// UnitPipeline, crash-safe checkpoints: the whole filter state (x, P, counters, model time and
// the leak detector) is saved every estimator.checkpoint_every_cycles cycles through
// CheckpointStore (tmp + fsync + rename + directory fsync), and a restarted daemon resumes from
// it instead of starting over: the charge estimate and the leak evidence continue. The cycle
// thread fills the snapshot; CheckpointWriter's thread writes it (the disk never delays a cycle).
#include <filesystem>
#include <stdexcept>
#include <vector>

#include "daemon/runtime/clock.hpp"
#include "daemon/runtime/unit_pipeline.hpp"

namespace hvac_twin::runtime {

// Start-up: creates the state directory and sizes the snapshot once (save() never allocates).
void UnitPipeline::open_checkpoints(const std::string& state_directory) {
  std::error_code ec;
  std::filesystem::create_directories(state_directory, ec);
  if (ec) throw std::runtime_error("state_directory " + state_directory + ": " + ec.message());
  const plant::ModelLayout& layout = model_->layout();
  const std::size_t leak_block = leak_ ? est::LeakDetector::kStateSize : 0;
  checkpoints_ = std::make_unique<CheckpointStore>(
      state_directory, unit_.id + ".ckpt",
      make_checkpoint_expectation(unit_.model.type, layout, unit_.id, leak_block));
  const std::size_t n = layout.states.size();
  snapshot_.model_fingerprint = model_fingerprint(unit_.model.type, layout);
  snapshot_.unit_id = unit_.id;
  snapshot_.x.assign(n, 0.0);
  snapshot_.P.assign(n * n, 0.0);
  snapshot_.leak_detector.assign(leak_block, 0.0);
  checkpoint_writer_ = std::make_unique<CheckpointWriter>(*checkpoints_, snapshot_, log_, unit_.id);
}

UnitPipeline::Resumed UnitPipeline::resume_from_checkpoint() {
  const LoadResult r = checkpoints_->load(realtime_ns());
  if (r.outcome != LoadOutcome::kLoaded) {
    const auto level =
        r.outcome == LoadOutcome::kNoCheckpoint ? spdlog::level::info : spdlog::level::warn;
    log_->log(level, "unit {}: {}", unit_.id, r.describe());
    return Resumed::kNo;
  }
  const FilterSnapshot& s = r.snapshot;
  const double age_s = static_cast<double>(realtime_ns() - s.wall_time_ns) * 1e-9;
  const double max_age_s = unit_.estimator.checkpoint_max_age_s;
  const bool stale = max_age_s > 0.0 && age_s > max_age_s;
  if (!(stale ? resume_properties(s) : filter_->restore(s.x, s.P, s.counters))) {
    log_->warn("unit {}: cold start: the filter refused checkpoint {} (cycle {})", unit_.id,
               checkpoints_->path(), s.cycle);
    return Resumed::kNo;
  }
  if (leak_ && !leak_->restore_state(s.leak_detector)) {
    // The filter state is good: keep it; the detector alone starts over (warm-up again).
    log_->warn("unit {}: the leak detector's saved state was refused; it starts over", unit_.id);
  }
  if (leak_) {
    // Transitions and references are logged against what was restored, not against a
    // fresh NORMAL: a unit resumed in LEAK does not announce NORMAL -> LEAK again.
    last_leak_state_ = leak_->report().state;
    references_logged_ = leak_->report().reference_learned;
  }
  model_time_s_ = s.model_time_s;
  const bool converging = (s.flags & kSnapshotConverging) != 0;
  resumed_releasing_ = !stale && (s.flags & kSnapshotReleasing) != 0;
  const auto charge = model_->layout().state("charge");
  const std::string what =
      stale ? fmt::format(
                  "its unit's properties only: it is older than "
                  "estimator.checkpoint_max_age_s {:.0f} s, so the operating state is "
                  "re-settled from the measured conditions (flag cold_start)",
                  max_age_s)
            : std::string(converging ? "still converging: flag cold_start" : "");
  const std::string ramp =
      resumed_releasing_
          ? fmt::format(
                "saved before the parameters were fully released: released again over "
                "{:.0f} s",
                unit_.estimator.parameter_release_s)
          : std::string();
  log_->info("unit {}: resumed from checkpoint {} (cycle {}, written {:.0f} s ago{}{}{}{}{}{})",
             unit_.id, checkpoints_->path(), s.cycle, age_s, what.empty() ? "" : ", ", what,
             ramp.empty() ? "" : ", ", ramp,
             charge ? fmt::format(", charge {:.4f} kg", s.x[*charge]) : std::string(),
             leak_ ? "; leak detector " + describe_leak_detector() : std::string());
  if (stale) return Resumed::kProperties;
  return converging ? Resumed::kConverging : Resumed::kWhole;
}

// Start-up only (allocates): a cold start from the measured conditions settled with the
// checkpoint's persistent states, which keep their covariance block.
bool UnitPipeline::resume_properties(const FilterSnapshot& s) {
  start_from_measurements(0.0, &s);
  const auto& states = model_->layout().states;
  const std::size_t n = states.size();
  std::vector<double> x(n), P(n * n, 0.0);
  const Eigen::VectorXd& x0 = filter_->state();
  const Eigen::MatrixXd& P0 = filter_->covariance();
  for (std::size_t i = 0; i < n; ++i) {
    const auto I = static_cast<Eigen::Index>(i);
    x[i] = states[i].persistent ? s.x[i] : x0(I);
    for (std::size_t j = 0; j < n; ++j) {
      const auto J = static_cast<Eigen::Index>(j);
      const bool kept = states[i].persistent && states[j].persistent;
      // The cold start's covariance is diagonal: no correlation across the two groups.
      if (kept)
        P[i * n + j] = s.P[i * n + j];
      else if (!states[i].persistent && !states[j].persistent)
        P[i * n + j] = P0(I, J);
    }
  }
  if (filter_->restore(x, P, s.counters)) return true;
  start_from_measurements(0.0);  // a plain cold start, without the refused values
  return false;
}

void UnitPipeline::save_checkpoint(std::int64_t stamp_ns, std::uint64_t cycle) {
  const Eigen::VectorXd& x = filter_->state();
  const Eigen::MatrixXd& P = filter_->covariance();
  const auto n = static_cast<Eigen::Index>(snapshot_.x.size());
  for (Eigen::Index i = 0; i < n; ++i) {
    snapshot_.x[static_cast<std::size_t>(i)] = x[i];
    for (Eigen::Index j = 0; j < n; ++j)  // row-major on disk, column-major in Eigen
      snapshot_.P[static_cast<std::size_t>(i * n + j)] = P(i, j);
  }
  snapshot_.counters = filter_->counters();
  snapshot_.cycle = cycle;
  snapshot_.model_time_s = model_time_s_;
  snapshot_.wall_time_ns = stamp_ns;
  snapshot_.flags = (cold_start_ ? kSnapshotConverging : 0u) |
                    (phases_->releasing(model_time_s_ - phases_from_s_) ? kSnapshotReleasing : 0u);
  if (leak_)
    leak_->save_state(std::span<double, est::LeakDetector::kStateSize>(
        snapshot_.leak_detector.data(), est::LeakDetector::kStateSize));
  checkpoint_writer_->submit(snapshot_);  // saved on the writer thread
}

void UnitPipeline::save_final_checkpoint() {
  if (!checkpoints_ || !initialized_ || cycles_since_checkpoint_ == 0) return;
  cycles_since_checkpoint_ = 0;
  save_checkpoint(last_stamp_ns_, last_cycle_);
  log_->info("unit {}: checkpoint of cycle {} handed to its writer on stop", unit_.id, last_cycle_);
}

}  // namespace hvac_twin::runtime
