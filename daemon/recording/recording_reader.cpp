#include "daemon/recording/recording_reader.hpp"

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <system_error>

#include "daemon/runtime/checkpoint.hpp"

namespace hvac_twin::recording {
namespace {

std::uint32_t u32_at(const std::byte* p) {
  std::uint32_t v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

}  // namespace

RecordingReader::RecordingReader(std::string path) : path_(std::move(path)) {
  std::error_code ec;
  if (std::filesystem::is_directory(path_, ec))
    throw RecordingError(path_ + ": a directory, not a recording file");
  const auto size = std::filesystem::file_size(path_, ec);
  if (ec) throw RecordingError(path_ + ": " + ec.message());
  size_ = size;
  auto file = std::make_unique<std::ifstream>(path_, std::ios::binary);
  if (!*file) throw RecordingError(path_ + ": cannot be opened for reading");
  in_ = std::move(file);
  read_header();
}

RecordingReader::RecordingReader(std::unique_ptr<std::istream> in, std::uint64_t size,
                                 std::string name)
    : path_(std::move(name)), in_(std::move(in)), size_(size) {
  if (!in_ || !*in_) throw RecordingError(path_ + ": cannot be read");
  read_header();
}

void RecordingReader::read_header() {
  std::byte preamble[kFilePreambleBytes];
  if (size_ < sizeof preamble || !in_->read(reinterpret_cast<char*>(preamble), sizeof preamble))
    throw RecordingError(path_ + ": shorter than a recording's 16-byte preamble (" +
                         std::to_string(size_) + " bytes)");
  if (std::memcmp(preamble, kMagic, sizeof kMagic) != 0)
    throw RecordingError(path_ + ": not an hvac-twin recording (no HTWREC01 magic)");
  const std::uint32_t length = u32_at(preamble + 8);
  if (length > kMaxHeaderBytes || kFilePreambleBytes + length > size_)
    throw RecordingError(path_ + ": header length " + std::to_string(length) +
                         " is longer than the file or the 1 MiB limit");
  std::vector<std::byte> text(length);
  in_->read(reinterpret_cast<char*>(text.data()), length);
  if (!*in_ || runtime::crc32c(text) != u32_at(preamble + 12))
    throw RecordingError(path_ + ": header damaged (checksum mismatch)");
  try {
    header_ = decode_header(text);
  } catch (const RecordingError& e) {
    throw RecordingError(path_ + ": " + e.what());
  }
  offset_ = kFilePreambleBytes + length;
  payload_.resize(payload_size(header_.points.size()));
}

void RecordingReader::fail(std::uint64_t offset, const std::string& what) const {
  throw RecordingError(path_ + ": record " + std::to_string(records_ + 1) + " at byte " +
                       std::to_string(offset) + ": " + what);
}

bool RecordingReader::next(RecordedCycle& out) {
  if (torn_tail_ || offset_ == size_) return false;
  const std::uint64_t at = offset_;
  const std::uint64_t left = size_ - at;
  auto torn = [&] {
    torn_tail_ = true;
    torn_offset_ = at;
    return false;
  };
  std::byte preamble[kRecordPreambleBytes];
  if (left < sizeof preamble) return torn();
  in_->read(reinterpret_cast<char*>(preamble), sizeof preamble);
  if (!*in_) fail(at, "read error");
  const std::uint32_t length = u32_at(preamble);
  if (length != payload_.size()) {
    // A length field a crash left half-written can only be the last thing in the file.
    if (left < kRecordPreambleBytes + payload_.size()) return torn();
    fail(at, "payload length " + std::to_string(length) + ", expected " +
                 std::to_string(payload_.size()) + " for the header's " +
                 std::to_string(header_.points.size()) + " points");
  }
  if (left < kRecordPreambleBytes + length) return torn();
  in_->read(reinterpret_cast<char*>(payload_.data()), length);
  if (!*in_) fail(at, "read error");
  if (runtime::crc32c(payload_) != u32_at(preamble + 4)) {
    if (left == kRecordPreambleBytes + length) return torn();
    fail(at, "checksum mismatch (damaged)");
  }
  std::string why;
  if (!decode_payload(payload_, out, why)) fail(at, why);
  offset_ = at + kRecordPreambleBytes + length;
  ++records_;
  return true;
}

std::vector<std::string> unit_recordings(const std::string& directory, const std::string& unit) {
  std::vector<std::pair<std::uint64_t, std::string>> found;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(directory, ec)) {
    const std::string name = e.path().filename().string();
    const std::string prefix = unit + ".";
    if (!name.starts_with(prefix) || !name.ends_with(kFileSuffix)) continue;
    const std::string seq =
        name.substr(prefix.size(), name.size() - prefix.size() - std::strlen(kFileSuffix));
    if (seq.empty() || seq.size() > 18 ||
        !std::all_of(seq.begin(), seq.end(), [](char c) { return c >= '0' && c <= '9'; }))
      continue;
    found.emplace_back(std::stoull(seq), e.path().string());
  }
  if (ec) throw RecordingError(directory + ": " + ec.message());
  std::sort(found.begin(), found.end());
  std::vector<std::string> out;
  for (auto& f : found)
    out.push_back(std::move(f.second));
  return out;
}

}  // namespace hvac_twin::recording
