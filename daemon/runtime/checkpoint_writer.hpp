// Saves one unit's checkpoints on a thread of its own, so that the disk never delays a cycle.
//
// A save is two fsyncs (file, directory). On the flash storage of an edge gateway (SD card,
// eMMC) an fsync takes milliseconds to seconds, and a failing card can stall it for longer;
// on the cycle thread that is a late cycle, skipped ticks and a missed DDS deadline (the
// subscribers would take the daemon for hung). Here the cycle thread only copies the snapshot
// into a buffer sized at construction (no allocation, a mutex held for the copy) and returns;
// the writer thread swaps it out and saves it. A snapshot submitted while the previous one is
// still waiting replaces it (the newest state is the one worth keeping) and is counted as
// superseded. Failures are logged once per episode, recovery once.
//
// The destructor saves what is still waiting and joins the thread.
#pragma once

#include <spdlog/logger.h>

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "daemon/runtime/checkpoint_store.hpp"

namespace hvac_twin::runtime {

struct CheckpointWriterStats {
  std::uint64_t saved = 0;
  std::uint64_t failed = 0;
  std::uint64_t superseded = 0;  // replaced by a newer snapshot before the writer took them
};

class CheckpointWriter {
 public:
  // `prototype`: a snapshot of the sizes every submitted one has (the buffers are sized from
  // it). `store` must outlive the writer; no other thread may save through it meanwhile.
  CheckpointWriter(CheckpointStore& store, const FilterSnapshot& prototype,
                   std::shared_ptr<spdlog::logger> log, std::string unit_id);
  ~CheckpointWriter();
  CheckpointWriter(const CheckpointWriter&) = delete;
  CheckpointWriter& operator=(const CheckpointWriter&) = delete;

  // Cycle thread: hands over the newest snapshot (same sizes as the prototype). Copies, never
  // allocates, never waits for the disk.
  void submit(const FilterSnapshot& snapshot) noexcept;

  [[nodiscard]] CheckpointWriterStats stats() const noexcept;

 private:
  void run();
  void report(const SaveStatus& status);

  CheckpointStore& store_;
  std::shared_ptr<spdlog::logger> log_;
  std::string unit_id_;

  std::mutex mutex_;
  std::condition_variable wake_;
  FilterSnapshot pending_;  // guarded by mutex_
  bool have_pending_ = false;
  bool stopping_ = false;
  FilterSnapshot writing_;  // the writer thread's

  bool failing_ = false;  // the writer thread's: the last save failed
  std::atomic<std::uint64_t> saved_{0}, failed_{0}, superseded_{0};
  std::thread thread_;  // last: started once everything above is built
};

}  // namespace hvac_twin::runtime
