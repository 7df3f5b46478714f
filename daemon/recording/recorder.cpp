#include "daemon/recording/recorder.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <system_error>

#include "daemon/recording/recording_reader.hpp"

namespace hvac_twin::recording {
namespace {

// The sequence number of a recording file's name (<unit>.<sequence>.htrec).
std::uint64_t sequence_of(const std::string& path) {
  const std::string name = std::filesystem::path(path).filename().string();
  const std::size_t dot = name.find('.');
  return std::stoull(name.substr(dot + 1));
}

}  // namespace

Recorder::Recorder(std::string directory, RecordingHeader header, std::uint64_t budget_bytes,
                   std::shared_ptr<spdlog::logger> log)
    : directory_(std::move(directory)),
      header_(std::move(header)),
      budget_bytes_(budget_bytes),
      file_bytes_limit_(std::max<std::uint64_t>(budget_bytes / 8, kMinFileBytes)),
      log_(std::move(log)),
      ring_(kRingRecords, std::vector<std::byte>(record_size(header_.points.size()))),
      ring_size_(kRingRecords, 0) {
  std::error_code ec;
  std::filesystem::create_directories(directory_, ec);
  if (ec || !std::filesystem::is_directory(directory_))
    throw std::runtime_error("recording directory " + directory_ + ": cannot be created (" +
                             (ec ? ec.message() : "not a directory") + ")");
  ::chmod(directory_.c_str(), 0750);
  (void)encode_header(header_);  // a header that does not fit throws here, not on the thread
  const auto existing = unit_recordings(directory_, header_.unit);
  next_sequence_ = existing.empty() ? 1 : sequence_of(existing.back()) + 1;
  thread_ = std::thread([this] { run(); });
}

Recorder::~Recorder() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_one();
  thread_.join();
  if (fd_ >= 0) ::close(fd_);
}

void Recorder::submit(std::uint64_t cycle, std::uint64_t ticks_since_last,
                      std::int64_t timestamp_ns, bool connected,
                      std::span<const modbus::PointSample> samples,
                      std::int64_t now_monotonic_ns) noexcept {
  if (samples.size() != header_.points.size()) {  // a caller's bug: never a damaged record
    failed_.fetch_add(1, std::memory_order_relaxed);
    return;
  }
  {
    std::lock_guard lock(mutex_);
    if (head_ - tail_ >= kRingRecords) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    const std::size_t slot = head_ % kRingRecords;
    ring_size_[slot] = encode_record(cycle, ticks_since_last, timestamp_ns, connected, samples,
                                     now_monotonic_ns, ring_[slot]);
    ++head_;
  }
  wake_.notify_one();
}

RecorderStats Recorder::stats() const noexcept {
  return {recorded_.load(), dropped_.load(), failed_.load(), files_deleted_.load()};
}

void Recorder::run() {
  std::uint64_t dropped_logged = 0;
  for (;;) {
    std::size_t slot = 0;
    {
      std::unique_lock lock(mutex_);
      wake_.wait(lock, [this] { return stopping_ || head_ != tail_; });
      if (head_ == tail_) return;  // stopping, nothing queued
      slot = tail_ % kRingRecords;
    }
    const std::size_t size = ring_size_[slot];
    if (size > 0 && write_record({ring_[slot].data(), size}))
      recorded_.fetch_add(1, std::memory_order_relaxed);
    else
      failed_.fetch_add(1, std::memory_order_relaxed);
    {
      std::lock_guard lock(mutex_);
      ++tail_;
    }
    const std::uint64_t dropped = dropped_.load(std::memory_order_relaxed);
    if (dropped != dropped_logged) {
      log_->warn(
          "unit {}: recording: {} cycles not recorded since start-up, the disk did not keep up "
          "with {} queued records",
          header_.unit, dropped, kRingRecords);
      dropped_logged = dropped;
    }
  }
}

bool Recorder::write_record(std::span<const std::byte> record) {
  if ((fd_ < 0 || file_bytes_ + record.size() > file_bytes_limit_) && !open_next_file())
    return false;
  if (!write_all(record)) return false;
  if (failing_) {
    failing_ = false;
    log_->info("unit {}: recording to {} again", header_.unit, directory_);
  }
  return true;
}

bool Recorder::write_all(std::span<const std::byte> bytes) {
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd_, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      // A partial record may be in the file: start a new one, so it stays a torn tail.
      note_failure(std::string("write: ") + std::strerror(errno));
      ::close(fd_);
      fd_ = -1;
      return false;
    }
    done += static_cast<std::size_t>(n);
  }
  file_bytes_ += bytes.size();
  return true;
}

bool Recorder::open_next_file() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  header_.sequence = next_sequence_;
  char name[32];
  std::snprintf(name, sizeof name, ".%08llu", static_cast<unsigned long long>(next_sequence_));
  const std::string path = directory_ + "/" + header_.unit + name + kFileSuffix;
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_APPEND | O_CLOEXEC, 0640);
  if (fd < 0) {
    note_failure("create " + path + ": " + std::strerror(errno));
    ++next_sequence_;  // an existing name (another writer?) is never reused
    return false;
  }
  ++next_sequence_;
  fd_ = fd;
  const std::vector<std::byte> header = encode_header(header_);
  file_bytes_ = 0;
  if (!write_all(header)) return false;
  enforce_budget();
  return true;
}

// Deletes the unit's oldest files (never the one being written) while they exceed the budget.
void Recorder::enforce_budget() {
  std::vector<std::string> files;
  try {
    files = unit_recordings(directory_, header_.unit);
  } catch (const RecordingError& e) {
    note_failure(e.what());
    return;
  }
  std::vector<std::uint64_t> sizes;
  std::uint64_t total = 0;
  for (const auto& f : files) {
    std::error_code ec;
    const auto s = std::filesystem::file_size(f, ec);
    sizes.push_back(ec ? 0 : s);
    total += sizes.back();
  }
  // The file just opened grows to file_bytes_limit_: leave room for it.
  total += file_bytes_limit_ - std::min(file_bytes_limit_, sizes.empty() ? 0 : sizes.back());
  for (std::size_t i = 0; i + 1 < files.size() && total > budget_bytes_; ++i) {
    std::error_code ec;
    if (std::filesystem::remove(files[i], ec)) {
      total -= sizes[i];
      files_deleted_.fetch_add(1, std::memory_order_relaxed);
    } else if (ec) {
      note_failure("delete " + files[i] + ": " + ec.message());
    }
  }
}

void Recorder::note_failure(const std::string& what) {
  if (failing_) return;
  failing_ = true;
  log_->error("unit {}: recording in {} failed ({}); the estimator runs on, cycles go unrecorded",
              header_.unit, directory_, what);
}

}  // namespace hvac_twin::recording
