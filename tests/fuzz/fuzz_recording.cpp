// libFuzzer target: the recording reader (daemon/recording/recording_reader.hpp). Input: the bytes
// of a recording file, read from memory (no file per input) record by record until the end or a
// RecordingError; any other exception escapes to libFuzzer as a finding.
// Invariants: an accepted header has the format version, a positive period and at most kMaxPoints
// points; every record has the header's point count, a known quality, ticks since the last cycle
// >= 1, and re-encodes to exactly its input bytes (a read time of 0 aside: an age of -1 or of
// the whole timestamp; and an age below -1, an older daemon's, read as 0); the records end at the
// end of the input or at a torn tail after them; the end stays the end.
//
// Random mutations almost never keep a CRC valid, so most inputs would stop at a checksum: each
// input is also read "sealed", with the header's and every record's CRC rewritten to match its
// declared length, so that the fuzzer explores the header and payload checks behind them.
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <memory>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include "daemon/recording/recording_reader.hpp"
#include "daemon/runtime/checkpoint.hpp"
#include "tests/fuzz/fuzz_input.hpp"

namespace rec = hvac_twin::recording;

namespace {

std::uint32_t u32_at(std::span<const std::byte> b, std::size_t at) {
  std::uint32_t v;
  std::memcpy(&v, b.data() + at, sizeof v);
  return v;
}

void check(std::span<const std::byte> bytes) {
  auto in = std::make_unique<std::istringstream>(
      std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
  std::unique_ptr<rec::RecordingReader> reader;
  try {
    reader = std::make_unique<rec::RecordingReader>(std::move(in), bytes.size(), "input");
  } catch (const rec::RecordingError& e) {
    HVAC_TWIN_FUZZ_CHECK(std::strncmp(e.what(), "input: ", 7) == 0);
    return;
  }
  const rec::RecordingHeader& h = reader->header();
  HVAC_TWIN_FUZZ_CHECK(h.version == rec::kFormatVersion);
  HVAC_TWIN_FUZZ_CHECK(h.period_s > 0.0);
  HVAC_TWIN_FUZZ_CHECK(h.points.size() <= rec::kMaxPoints);
  const std::size_t points = h.points.size();
  const std::size_t record = rec::record_size(points);
  std::size_t offset = rec::kFilePreambleBytes + u32_at(bytes, 8);

  rec::RecordedCycle c;
  std::vector<std::byte> again(record);
  std::uint64_t returned = 0;
  try {
    while (reader->next(c)) {
      ++returned;
      HVAC_TWIN_FUZZ_CHECK(offset + record <= bytes.size());
      HVAC_TWIN_FUZZ_CHECK(c.samples.size() == points);
      HVAC_TWIN_FUZZ_CHECK(c.ticks_since_last >= 1);
      for (const auto& s : c.samples)
        HVAC_TWIN_FUZZ_CHECK(s.quality <= hvac_twin::modbus::PointQuality::kOutOfRange);
      // The reader's read times are timestamp - age: re-encoded at `now` = the timestamp.
      HVAC_TWIN_FUZZ_CHECK(rec::encode_record(c.cycle, c.ticks_since_last, c.timestamp_ns,
                                              c.connected, c.samples, c.timestamp_ns,
                                              again) == record);
      const std::byte* input = bytes.data() + offset;
      for (std::size_t i = 0; i < points; ++i) {
        const std::size_t age_at =
            rec::kRecordPreambleBytes + rec::kCycleBytes + i * rec::kPointBytes + 10;
        std::int64_t age;
        std::memcpy(&age, input + age_at, sizeof age);
        if (age < -1) {
          // An older daemon's read after the cycle's clock reading: read at the cycle's time
          // (re-encoded as age 0).
          HVAC_TWIN_FUZZ_CHECK(c.samples[i].read_time_ns == c.timestamp_ns);
        } else if (c.samples[i].read_time_ns == 0) {
          // Read time 0 stands for never read (age -1) and for an age of the whole timestamp.
          HVAC_TWIN_FUZZ_CHECK(age == -1 || age == c.timestamp_ns);
        } else {
          continue;
        }
        std::memcpy(again.data() + age_at, &age, sizeof age);
      }
      // The payload (its CRC checked by the reader) is canonical: no byte the decoder ignores.
      HVAC_TWIN_FUZZ_CHECK(std::memcmp(again.data(), input, 4) == 0);
      HVAC_TWIN_FUZZ_CHECK(std::memcmp(again.data() + rec::kRecordPreambleBytes,
                                       input + rec::kRecordPreambleBytes,
                                       record - rec::kRecordPreambleBytes) == 0);
      offset += record;
    }
  } catch (const rec::RecordingError& e) {
    const std::string what = e.what();
    HVAC_TWIN_FUZZ_CHECK(what.starts_with("input: record " + std::to_string(reader->records() + 1) +
                                          " at byte " + std::to_string(offset) + ": "));
    return;
  }
  HVAC_TWIN_FUZZ_CHECK(reader->records() == returned);
  if (reader->torn_tail()) {
    HVAC_TWIN_FUZZ_CHECK(reader->torn_offset() == offset);
    HVAC_TWIN_FUZZ_CHECK(offset < bytes.size() && bytes.size() - offset <= record);
  } else {
    HVAC_TWIN_FUZZ_CHECK(offset == bytes.size());
  }
  HVAC_TWIN_FUZZ_CHECK(!reader->next(c));
}

void put_u32(std::vector<std::byte>& b, std::size_t at, std::uint32_t v) {
  std::memcpy(b.data() + at, &v, sizeof v);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto bytes = std::as_bytes(std::span(data, size));
  check(bytes);
  if (size < rec::kFilePreambleBytes) return 0;
  std::vector<std::byte> sealed(bytes.begin(), bytes.end());
  const std::span<const std::byte> s(sealed);
  const std::size_t header = u32_at(s, 8);
  if (header > size - rec::kFilePreambleBytes) return 0;
  put_u32(sealed, 12, hvac_twin::runtime::crc32c(s.subspan(rec::kFilePreambleBytes, header)));
  for (std::size_t at = rec::kFilePreambleBytes + header; size - at >= rec::kRecordPreambleBytes;) {
    const std::size_t payload = u32_at(s, at);
    if (payload > size - at - rec::kRecordPreambleBytes) break;
    put_u32(sealed, at + 4,
            hvac_twin::runtime::crc32c(s.subspan(at + rec::kRecordPreambleBytes, payload)));
    at += rec::kRecordPreambleBytes + payload;
  }
  if (std::memcmp(sealed.data(), data, size) != 0) check(sealed);
  return 0;
}
