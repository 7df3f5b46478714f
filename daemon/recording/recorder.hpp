// Records one unit's cycles (recording_format.hpp) on a thread of its own: the disk never delays
// a cycle.
//
// The cycle thread encodes its snapshot into a ring of record buffers sized at construction (a
// mutex held for the copy; no allocation, no wait for the disk) and returns. The writer thread
// appends the records to <directory>/<unit>.<sequence>.htrec. A file that reached its share of
// the budget is closed and the next one opened; the oldest files of the unit are then deleted
// until the unit's files fit the budget. Every daemon start opens a new file, so a torn last
// record (a crash in a write) is only ever at the end of a file, where the reader skips it.
// A ring that is full (the disk stalled for kRingRecords cycles) drops the newest record and
// counts it; a failing disk is logged once per episode, its recovery once.
//
// The destructor writes what is still queued and joins the thread.
#pragma once

#include <spdlog/logger.h>

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "daemon/recording/recording_format.hpp"

namespace hvac_twin::recording {

struct RecorderStats {
  std::uint64_t recorded = 0;       // records written to a file
  std::uint64_t dropped = 0;        // the ring was full
  std::uint64_t failed = 0;         // records a write error lost
  std::uint64_t files_deleted = 0;  // the oldest files, over the budget
};

class Recorder {
 public:
  static constexpr std::size_t kRingRecords = 256;
  // The smallest file (a budget below 8 files' worth still rotates through whole files).
  static constexpr std::uint64_t kMinFileBytes = 64 * 1024;

  // `header`: the unit's (its sequence is set per file). Creates `directory` (mode 0750) if it is
  // missing; throws std::runtime_error naming it if it cannot be created. A budget of B bytes
  // keeps at most B bytes of the unit's recordings (files of max(B / 8, kMinFileBytes)).
  Recorder(std::string directory, RecordingHeader header, std::uint64_t budget_bytes,
           std::shared_ptr<spdlog::logger> log);
  ~Recorder();
  Recorder(const Recorder&) = delete;
  Recorder& operator=(const Recorder&) = delete;

  // Cycle thread: queues the cycle's snapshot (header().points.size() samples). Never allocates,
  // never waits for the disk.
  void submit(std::uint64_t cycle, std::uint64_t ticks_since_last, std::int64_t timestamp_ns,
              bool connected, std::span<const modbus::PointSample> samples,
              std::int64_t now_monotonic_ns) noexcept;

  [[nodiscard]] RecorderStats stats() const noexcept;
  [[nodiscard]] const std::string& directory() const { return directory_; }

 private:
  void run();
  bool write_record(std::span<const std::byte> record);  // the writer thread's
  bool write_all(std::span<const std::byte> bytes);      // to the open file
  bool open_next_file();
  void enforce_budget();
  void note_failure(const std::string& what);

  std::string directory_;
  RecordingHeader header_;
  std::uint64_t budget_bytes_;
  std::uint64_t file_bytes_limit_;
  std::shared_ptr<spdlog::logger> log_;

  std::mutex mutex_;
  std::condition_variable wake_;
  std::vector<std::vector<std::byte>> ring_;  // kRingRecords records
  std::vector<std::size_t> ring_size_;
  std::uint64_t head_ = 0, tail_ = 0;  // guarded by mutex_; the writer owns [tail_, head_)
  bool stopping_ = false;

  // The writer thread's.
  int fd_ = -1;
  std::uint64_t file_bytes_ = 0;
  std::uint64_t next_sequence_ = 0;
  bool failing_ = false;

  std::atomic<std::uint64_t> recorded_{0}, dropped_{0}, failed_{0}, files_deleted_{0};
  std::thread thread_;  // last: started once everything above is built
};

}  // namespace hvac_twin::recording
