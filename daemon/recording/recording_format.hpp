// The daemon's recording format: per unit, every cycle's point snapshot as the filter saw it.
//
// A file is a header then records, all integers little-endian, doubles IEEE-754 binary64:
//   magic "HTWREC01" (8 bytes), u32 header length, u32 CRC-32C of the header, the header (JSON:
//   format version, site, unit, model type, period, the run's start, the file's sequence number
//   in the run, and the unit's points with their unit and role, in configuration order);
//   then records: u32 payload length, u32 CRC-32C of the payload, the payload:
//     u64 cycle (tick index), u64 ticks since the last cycle, i64 timestamp (CLOCK_REALTIME ns),
//     u32 point count, u8 flags (bit 0: Modbus connected), 3 bytes zero,
//     per point: f64 value, u8 quality (modbus::PointQuality), u8 exception code,
//                i64 age of the value at the cycle [ns] (-1: never read; 0 for a read that
//                completed after the cycle took its clock reading; older daemons wrote such a
//                read as a negative age, which reads as 0).
// A record is written whole or, after a crash, torn: the reader skips a torn last record and
// refuses a damaged one before the end, naming the file, the record and its byte offset.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "io/modbus/point_sample.hpp"

namespace hvac_twin::recording {

inline constexpr char kMagic[8] = {'H', 'T', 'W', 'R', 'E', 'C', '0', '1'};
inline constexpr int kFormatVersion = 1;
inline constexpr std::size_t kFilePreambleBytes = 16;   // magic, header length, header CRC
inline constexpr std::size_t kRecordPreambleBytes = 8;  // payload length, payload CRC
inline constexpr std::size_t kCycleBytes = 32;          // the payload before its points
inline constexpr std::size_t kPointBytes = 18;
inline constexpr std::size_t kMaxPoints = 4096;  // a unit has far fewer; bounds a bad length
inline constexpr std::size_t kMaxHeaderBytes = 1u << 20;
inline constexpr char kFileSuffix[] = ".htrec";

constexpr std::size_t payload_size(std::size_t points) {
  return kCycleBytes + kPointBytes * points;
}
constexpr std::size_t record_size(std::size_t points) {
  return kRecordPreambleBytes + payload_size(points);
}

struct RecordedPoint {
  std::string name;
  std::string unit;  // the point's engineering unit
  std::string role;  // "measured" or "input"
};

struct RecordingHeader {
  int version = kFormatVersion;
  std::string site;
  std::string unit;
  std::string model;
  double period_s = 0.0;       // model seconds per tick
  std::int64_t run_ns = 0;     // CLOCK_REALTIME when the recording daemon run started
  std::uint64_t sequence = 0;  // file number in the unit's recording directory
  std::vector<RecordedPoint> points;
};

// One cycle's snapshot. samples[i].read_time_ns is timestamp_ns - age (CLOCK_REALTIME), or 0 for
// a point never read: a replay has no monotonic clock of the recording daemon.
struct RecordedCycle {
  std::uint64_t cycle = 0;
  std::uint64_t ticks_since_last = 1;
  std::int64_t timestamp_ns = 0;
  bool connected = false;
  std::vector<modbus::PointSample> samples;
};

// A file that is not a recording, or damaged: the message names the file and what was wrong.
class RecordingError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The file's preamble and header. Throws std::invalid_argument for a header that does not fit.
std::vector<std::byte> encode_header(const RecordingHeader& header);
// Parses the header text; throws RecordingError(what was wrong) without the file name.
RecordingHeader decode_header(std::span<const std::byte> json);

// Encodes one record into out (record_size(samples.size()) bytes); `now_monotonic_ns` is the
// time base of samples[i].read_time_ns. Returns the bytes written, 0 if out is too small.
// No allocation.
std::size_t encode_record(std::uint64_t cycle, std::uint64_t ticks_since_last,
                          std::int64_t timestamp_ns, bool connected,
                          std::span<const modbus::PointSample> samples,
                          std::int64_t now_monotonic_ns, std::span<std::byte> out) noexcept;
// Decodes a payload whose CRC was checked; false (out unspecified) if it is not plausible, with
// `why` set.
bool decode_payload(std::span<const std::byte> payload, RecordedCycle& out, std::string& why);

}  // namespace hvac_twin::recording
