// Reads a recording file (recording_format.hpp) record by record, from a stream so that a day's
// recording is never held in memory.
#pragma once

#include <cstdint>
#include <istream>
#include <memory>
#include <string>
#include <vector>

#include "daemon/recording/recording_format.hpp"

namespace hvac_twin::recording {

class RecordingReader {
 public:
  // Opens the file and reads its header; throws RecordingError naming the file and what was
  // wrong (missing, unreadable, not a recording, a damaged header, another format version).
  explicit RecordingReader(std::string path);
  // The same over `size` bytes of a stream (a fuzzer's input: no file per input); `name` stands
  // for the file in messages. The size, not the stream's end, tells a torn tail.
  RecordingReader(std::unique_ptr<std::istream> in, std::uint64_t size, std::string name);

  [[nodiscard]] const RecordingHeader& header() const { return header_; }
  [[nodiscard]] const std::string& path() const { return path_; }

  // The next record into `out`; false at the end. A torn last record (cut short, or its checksum
  // wrong with nothing after it: a write the crash interrupted) ends the file and sets
  // torn_tail(). A damaged record before the end, or one whose point count differs from the
  // header's, throws RecordingError naming the file, the record number (from 1) and its offset.
  bool next(RecordedCycle& out);

  [[nodiscard]] bool torn_tail() const { return torn_tail_; }
  [[nodiscard]] std::uint64_t records() const { return records_; }  // read so far
  [[nodiscard]] std::uint64_t torn_offset() const { return torn_offset_; }

 private:
  void read_header();
  [[noreturn]] void fail(std::uint64_t offset, const std::string& what) const;

  std::string path_;
  std::unique_ptr<std::istream> in_;
  std::uint64_t size_ = 0;
  std::uint64_t offset_ = 0;  // of the next record
  RecordingHeader header_;
  std::vector<std::byte> payload_;
  std::uint64_t records_ = 0;
  bool torn_tail_ = false;
  std::uint64_t torn_offset_ = 0;
};

// The recording files of `unit` in `directory` (<unit>.<sequence>.htrec), oldest first.
std::vector<std::string> unit_recordings(const std::string& directory, const std::string& unit);

}  // namespace hvac_twin::recording
