#include "daemon/runtime/checkpoint_writer.hpp"

#include <cstring>
#include <utility>

namespace hvac_twin::runtime {

CheckpointWriter::CheckpointWriter(CheckpointStore& store, const FilterSnapshot& prototype,
                                   std::shared_ptr<spdlog::logger> log, std::string unit_id)
    : store_(store),
      log_(std::move(log)),
      unit_id_(std::move(unit_id)),
      pending_(prototype),
      writing_(prototype),
      thread_([this] { run(); }) {}

CheckpointWriter::~CheckpointWriter() {
  {
    const std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_one();
  thread_.join();
}

void CheckpointWriter::submit(const FilterSnapshot& snapshot) noexcept {
  {
    const std::lock_guard lock(mutex_);
    // Equal sizes: vector and string assignment reuse the buffers (no allocation).
    pending_ = snapshot;
    if (have_pending_) superseded_.fetch_add(1, std::memory_order_relaxed);
    have_pending_ = true;
  }
  wake_.notify_one();
}

CheckpointWriterStats CheckpointWriter::stats() const noexcept {
  return {saved_.load(std::memory_order_relaxed), failed_.load(std::memory_order_relaxed),
          superseded_.load(std::memory_order_relaxed)};
}

void CheckpointWriter::run() {
  for (;;) {
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [this] { return have_pending_ || stopping_; });
      if (!have_pending_) return;  // stopping, nothing left to save
      std::swap(pending_, writing_);
      have_pending_ = false;
    }
    report(store_.save(writing_));
  }
}

void CheckpointWriter::report(const SaveStatus& status) {
  if (status.ok()) {
    saved_.fetch_add(1, std::memory_order_relaxed);
    if (failing_) log_->info("unit {}: checkpoints are saved again", unit_id_);
    failing_ = false;
    return;
  }
  failed_.fetch_add(1, std::memory_order_relaxed);
  if (!failing_)  // once per episode: a full disk must not flood the journal
    log_->error("unit {}: checkpoint not saved ({} failed: {}); the previous one is kept", unit_id_,
                to_string(status.failed_step), std::strerror(status.error));
  failing_ = true;
}

}  // namespace hvac_twin::runtime
