// UnitPipeline, crash-safe checkpoints: the whole filter state (x, P, counters, model time and
// the leak detector) is saved every estimator.checkpoint_every_cycles cycles through
// CheckpointStore (tmp + fsync + rename + directory fsync), and a restarted daemon resumes from
// it instead of starting over: the charge estimate and the leak evidence continue. The cycle
// thread fills the snapshot; CheckpointWriter's thread writes it (the disk never delays a cycle).
#include <filesystem>
#include <stdexcept>

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

bool UnitPipeline::resume_from_checkpoint(bool& converging) {
  const LoadResult r = checkpoints_->load(realtime_ns());
  if (r.outcome != LoadOutcome::kLoaded) {
    const auto level =
        r.outcome == LoadOutcome::kNoCheckpoint ? spdlog::level::info : spdlog::level::warn;
    log_->log(level, "unit {}: {}", unit_.id, r.describe());
    return false;
  }
  const FilterSnapshot& s = r.snapshot;
  if (!filter_->restore(s.x, s.P, s.counters)) {
    log_->warn("unit {}: cold start: the filter refused checkpoint {} (cycle {})", unit_.id,
               checkpoints_->path(), s.cycle);
    return false;
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
  converging = (s.flags & kSnapshotConverging) != 0;
  const double age_s = static_cast<double>(realtime_ns() - s.wall_time_ns) * 1e-9;
  const auto charge = model_->layout().state("charge");
  log_->info("unit {}: resumed from checkpoint {} (cycle {}, written {:.0f} s ago{}{}{})", unit_.id,
             checkpoints_->path(), s.cycle, age_s,
             converging ? ", still converging: flag cold_start" : "",
             charge ? fmt::format(", charge {:.4f} kg", s.x[*charge]) : std::string(),
             leak_ ? "; leak detector " + describe_leak_detector() : std::string());
  return true;
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
  snapshot_.flags = cold_start_ ? kSnapshotConverging : 0;
  if (leak_)
    leak_->save_state(std::span<double, est::LeakDetector::kStateSize>(
        snapshot_.leak_detector.data(), est::LeakDetector::kStateSize));
  checkpoint_writer_->submit(snapshot_);  // saved on the writer thread
}

}  // namespace hvac_twin::runtime
