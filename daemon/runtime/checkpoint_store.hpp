// Crash-safe checkpoint file of one unit: <directory>/<name>, written atomically.
//
// save(): encode into a buffer sized at construction; write <name>.tmp (O_TRUNC, 0600) in the
// same directory, all of it (short writes and EINTR continued); fsync it; close it; rename it
// over <name>; fsync the directory.
//
// Why that is atomic and durable (ext4, xfs; any POSIX file system with journalled metadata):
//  - rename(2) replaces the directory entry atomically: every reader, and the journalled file
//    system after a crash, finds under <name> either the old inode or the new one, never a mix
//    and never no file (whether the new inode's data reached the disk is the fsync point below).
//    The temporary is in the same directory, hence the same file system, so the rename cannot
//    turn into a copy (EXDEV would be an error, never a partial file).
//  - kill -9 (or a crash of the daemon alone) loses nothing the process had handed to write():
//    the page cache belongs to the kernel. Against it, write-to-temporary plus rename suffices:
//    killed before the rename, <name> is the previous checkpoint (and a stray .tmp, which load()
//    deletes); after it, the new one. The kill test (tests/checkpoint) checks exactly this.
//  - A power cut or kernel crash loses the page cache. Without the fsync before the rename the
//    journal may commit the rename before the data blocks are written (delayed allocation),
//    leaving an empty or zero-filled <name> after reboot; ext4's auto_da_alloc heuristic only
//    mitigates this (and can be turned off), xfs and others promise nothing. fsync(tmp) first
//    makes the new data and inode durable; fsync(directory) after the rename makes the new
//    entry durable, so once save() returns ok the new checkpoint survives a power cut, and
//    before that the old one does. That argument, not the kill test, covers power loss. A disk
//    that acknowledges flushes it has not done would still be caught by the CRC at load.
//  - A failed fsync is never retried: after an I/O error Linux may mark the dirty pages clean
//    (the 2018 "fsyncgate" finding), so a second fsync can succeed with the data lost. The
//    temporary is unlinked and the next save() writes a fresh file.
//
// On any failure save() unlinks the temporary, leaves <name> as it was (except after a failed
// directory fsync: the new file is then in place but its durability unknown) and returns the
// step and errno. It never throws, never aborts, and allocates nothing.
//
// load() (start-up) deletes a stray <name>.tmp, reads <name>, decodes and validates it. A
// missing file is a cold start, not an error; a rejected one is renamed to <name>.rejected (an
// operator can inspect it; the next rejection replaces it) and the daemon cold-starts with the
// reason, which the caller logs and flags.
//
// The directory must exist (systemd's StateDirectory= creates it). One thread uses an instance.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "daemon/runtime/checkpoint.hpp"

namespace hvac_twin::runtime {

enum class SaveStep : std::uint8_t {
  kNone,
  kEncode,  // the snapshot's sizes differ from those the store was built for (errno EINVAL)
  kOpen,
  kWrite,
  kFsyncFile,
  kClose,
  kRename,
  kFsyncDir,  // the new checkpoint is in place; its durability is unknown
};
std::string_view to_string(SaveStep step);

struct SaveStatus {
  SaveStep failed_step = SaveStep::kNone;
  int error = 0;  // errno of the failed step
  [[nodiscard]] bool ok() const { return failed_step == SaveStep::kNone; }
};

enum class LoadOutcome : std::uint8_t {
  kLoaded,
  kNoCheckpoint,  // no file: a cold start, not an error
  kRejected,      // decoded or validated with an error (reason); moved aside
  kReadError,     // the file exists but could not be read (error)
};
std::string_view to_string(LoadOutcome outcome);

struct LoadResult {
  LoadOutcome outcome = LoadOutcome::kNoCheckpoint;
  CheckpointStatus reason;         // kRejected: why
  int error = 0;                   // kReadError: errno; kRejected: errno of a failed move aside
  bool moved_aside = false;        // kRejected: renamed to rejected_path()
  bool removed_stray_tmp = false;  // a temporary of an interrupted save was deleted
  FilterSnapshot snapshot;         // kLoaded
  [[nodiscard]] bool cold_start() const { return outcome != LoadOutcome::kLoaded; }
  // One line for the log: outcome, cycle or reason.
  [[nodiscard]] std::string describe() const;
};

class CheckpointStore {
 public:
  // Builds the paths and sizes the encoding buffer for snapshots of `expected` (allocates).
  CheckpointStore(std::string directory, std::string file_name, CheckpointExpectation expected);

  // Writes the snapshot atomically (see above). No allocation, no exception.
  SaveStatus save(const FilterSnapshot& snapshot) noexcept;

  // Reads the checkpoint, checking it against the expectation (age against now_realtime_ns).
  // Start-up only: allocates. Never throws.
  LoadResult load(std::int64_t now_realtime_ns);

  [[nodiscard]] const std::string& path() const { return path_; }
  [[nodiscard]] const std::string& tmp_path() const { return tmp_path_; }
  [[nodiscard]] const std::string& rejected_path() const { return rejected_path_; }
  [[nodiscard]] const CheckpointExpectation& expected() const { return expected_; }

 private:
  SaveStatus fail(SaveStep step, int error, int fd) noexcept;

  std::string directory_, path_, tmp_path_, rejected_path_;
  CheckpointExpectation expected_;
  std::vector<std::byte> buffer_;
};

}  // namespace hvac_twin::runtime
