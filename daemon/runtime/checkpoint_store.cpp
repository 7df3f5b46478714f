#include "daemon/runtime/checkpoint_store.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <utility>

namespace hvac_twin::runtime {
namespace {

int open_retrying(const char* path, int flags, mode_t mode = 0) {
  int fd;
  do {
    fd = ::open(path, flags, mode);
  } while (fd < 0 && errno == EINTR);
  return fd;
}

// Writes all of `bytes`: a regular file may take less than asked (a signal, RLIMIT_FSIZE, a
// full disk part-way); 0 on success, else errno.
int write_all(int fd, std::span<const std::byte> bytes) {
  while (!bytes.empty()) {
    const ssize_t w = ::write(fd, bytes.data(), bytes.size());
    if (w < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    if (w == 0) return EIO;  // no progress and no error: do not spin
    bytes = bytes.subspan(static_cast<std::size_t>(w));
  }
  return 0;
}

}  // namespace

std::string_view to_string(SaveStep step) {
  switch (step) {
    case SaveStep::kNone:
      return "none";
    case SaveStep::kEncode:
      return "encode";
    case SaveStep::kOpen:
      return "open";
    case SaveStep::kWrite:
      return "write";
    case SaveStep::kFsyncFile:
      return "fsync-file";
    case SaveStep::kClose:
      return "close";
    case SaveStep::kRename:
      return "rename";
    case SaveStep::kFsyncDir:
      return "fsync-dir";
  }
  return "unknown";
}

std::string_view to_string(LoadOutcome outcome) {
  switch (outcome) {
    case LoadOutcome::kLoaded:
      return "loaded";
    case LoadOutcome::kNoCheckpoint:
      return "no checkpoint";
    case LoadOutcome::kRejected:
      return "rejected";
    case LoadOutcome::kReadError:
      return "read error";
  }
  return "unknown";
}

std::string LoadResult::describe() const {
  std::string s(to_string(outcome));
  switch (outcome) {
    case LoadOutcome::kLoaded:
      s += ": cycle " + std::to_string(snapshot.cycle) + ", model time " +
           std::to_string(snapshot.model_time_s) + " s";
      break;
    case LoadOutcome::kNoCheckpoint:
      s += ": cold start";
      break;
    case LoadOutcome::kRejected:
      s += " (" + std::string(to_string(reason.error)) + ": " + reason.message + "), ";
      s += moved_aside ? "moved aside"
                       : "could not be moved aside (errno " + std::to_string(error) + ")";
      s += "; cold start";
      break;
    case LoadOutcome::kReadError:
      s += ": errno " + std::to_string(error) + "; cold start";
      break;
  }
  if (removed_stray_tmp) s += "; removed the temporary of an interrupted save";
  return s;
}

CheckpointStore::CheckpointStore(std::string directory, std::string file_name,
                                 CheckpointExpectation expected)
    : directory_(std::move(directory)), expected_(std::move(expected)) {
  path_ = directory_ + "/" + file_name;
  tmp_path_ = path_ + ".tmp";
  rejected_path_ = path_ + ".rejected";
  buffer_.resize(checkpoint_size(expected_.num_states, expected_.model_fingerprint.size(),
                                 expected_.unit_id.size(), expected_.leak_block_size));
}

SaveStatus CheckpointStore::fail(SaveStep step, int error, int fd) noexcept {
  if (fd >= 0) ::close(fd);
  // Whatever the step, no temporary stays behind (ENOENT after a rename is expected).
  ::unlink(tmp_path_.c_str());
  return SaveStatus{step, error};
}

SaveStatus CheckpointStore::save(const FilterSnapshot& snapshot) noexcept {
  if (buffer_.empty() || checkpoint_size(snapshot) != buffer_.size() ||
      encode_checkpoint(snapshot, buffer_) != buffer_.size())
    return SaveStatus{SaveStep::kEncode, EINVAL};
  const int fd = open_retrying(tmp_path_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  if (fd < 0) return fail(SaveStep::kOpen, errno, -1);
  if (const int e = write_all(fd, buffer_); e != 0) return fail(SaveStep::kWrite, e, fd);
  // Not retried, even on EINTR: after a failed fsync the data's state is unknown.
  if (::fsync(fd) != 0) return fail(SaveStep::kFsyncFile, errno, fd);
  // close() is not retried either: Linux releases the descriptor even when it reports EINTR.
  if (::close(fd) != 0) return fail(SaveStep::kClose, errno, -1);
  if (::rename(tmp_path_.c_str(), path_.c_str()) != 0) return fail(SaveStep::kRename, errno, -1);
  const int dir = open_retrying(directory_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir < 0) return SaveStatus{SaveStep::kFsyncDir, errno};
  if (::fsync(dir) != 0) {
    const int e = errno;
    ::close(dir);
    return SaveStatus{SaveStep::kFsyncDir, e};
  }
  ::close(dir);
  return {};
}

LoadResult CheckpointStore::load(std::int64_t now_realtime_ns) {
  LoadResult result;
  result.removed_stray_tmp = ::unlink(tmp_path_.c_str()) == 0;
  const int fd = open_retrying(path_.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    result.error = errno;
    result.outcome = errno == ENOENT ? LoadOutcome::kNoCheckpoint : LoadOutcome::kReadError;
    return result;
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    result.error = errno;
    ::close(fd);
    result.outcome = LoadOutcome::kReadError;
    return result;
  }
  const auto size = static_cast<std::size_t>(st.st_size);
  const std::size_t largest = checkpoint_size(kCheckpointMaxStates, kCheckpointMaxText,
                                              kCheckpointMaxText, kCheckpointMaxLeakBlock);
  std::vector<std::byte> bytes;
  if (size <= largest) {
    bytes.resize(size);
    std::size_t got = 0;
    while (got < size) {
      const ssize_t r = ::read(fd, bytes.data() + got, size - got);
      if (r < 0 && errno == EINTR) continue;
      if (r < 0) {
        result.error = errno;
        ::close(fd);
        result.outcome = LoadOutcome::kReadError;
        return result;
      }
      if (r == 0) break;  // shrank under us: decode what is there (it will be rejected)
      got += static_cast<std::size_t>(r);
    }
    bytes.resize(got);
  }
  ::close(fd);

  if (size > largest) {
    result.reason = {CheckpointError::kImplausible,
                     std::to_string(size) + " bytes, larger than any checkpoint"};
  } else {
    DecodedCheckpoint decoded = decode_checkpoint(bytes);
    result.reason = decoded.ok() ? validate_checkpoint(decoded.snapshot, expected_, now_realtime_ns)
                                 : std::move(decoded.status);
    if (result.reason.ok()) {
      result.outcome = LoadOutcome::kLoaded;
      result.snapshot = std::move(decoded.snapshot);
      return result;
    }
  }
  result.outcome = LoadOutcome::kRejected;
  // Moved aside rather than deleted, for an operator to inspect; the next save writes afresh.
  result.moved_aside = ::rename(path_.c_str(), rejected_path_.c_str()) == 0;
  if (!result.moved_aside) result.error = errno;
  return result;
}

}  // namespace hvac_twin::runtime
