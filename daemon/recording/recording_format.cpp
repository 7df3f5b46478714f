#include "daemon/recording/recording_format.hpp"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <nlohmann/json.hpp>
#include <type_traits>

#include "daemon/runtime/checkpoint.hpp"

namespace hvac_twin::recording {
namespace {

static_assert(std::endian::native == std::endian::little,
              "the recording format is little-endian; add byte swaps for this target");

template <typename T>
void put(std::byte*& at, T v) noexcept {
  std::memcpy(at, &v, sizeof v);
  at += sizeof v;
}

template <typename T>
T get(const std::byte*& at) noexcept {
  T v;
  std::memcpy(&v, at, sizeof v);
  at += sizeof v;
  return v;
}

std::string text_field(const nlohmann::json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end() || !it->is_string())
    throw RecordingError(std::string("header: \"") + key + "\" is missing or not a string");
  return it->get<std::string>();
}

// An optional integer field. A float ("run_ns": 1e300) would reach nlohmann's static_cast to the
// integer type, which is undefined behaviour out of range, so only JSON integers are read.
template <typename Int>
Int integer_field(const nlohmann::json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end()) return Int{0};
  const bool fits =
      it->is_number_unsigned()
          ? it->get<std::uint64_t>() <= std::uint64_t(std::numeric_limits<Int>::max())
          : it->is_number_integer() && (std::is_signed_v<Int> || it->get<std::int64_t>() >= 0);
  if (!fits)
    throw RecordingError(std::string("header: \"") + key + "\" is not an integer in range");
  return it->get<Int>();
}

}  // namespace

std::vector<std::byte> encode_header(const RecordingHeader& header) {
  if (header.points.size() > kMaxPoints)
    throw std::invalid_argument("recording: more than 4096 points");
  nlohmann::json points = nlohmann::json::array();
  for (const auto& p : header.points)
    points.push_back({{"name", p.name}, {"unit", p.unit}, {"role", p.role}});
  const nlohmann::json j = {{"format", "hvac-twin recording"},
                            {"version", header.version},
                            {"site", header.site},
                            {"unit", header.unit},
                            {"model", header.model},
                            {"period_s", header.period_s},
                            {"run_ns", header.run_ns},
                            {"sequence", header.sequence},
                            {"points", points}};
  const std::string text = j.dump();
  if (text.size() > kMaxHeaderBytes) throw std::invalid_argument("recording: header too long");
  std::vector<std::byte> out(kFilePreambleBytes + text.size());
  std::byte* at = out.data();
  std::memcpy(at, kMagic, sizeof kMagic);
  at += sizeof kMagic;
  put(at, static_cast<std::uint32_t>(text.size()));
  const auto* bytes = reinterpret_cast<const std::byte*>(text.data());
  put(at, runtime::crc32c({bytes, text.size()}));
  std::memcpy(at, text.data(), text.size());
  return out;
}

namespace {

RecordingHeader header_of(const nlohmann::json& j) {
  if (!j.is_object() || j.value("format", "") != "hvac-twin recording")
    throw RecordingError("header: not an hvac-twin recording header");
  RecordingHeader h;
  const auto version = j.find("version");
  if (version == j.end() || !version->is_number_integer() || *version != kFormatVersion)
    throw RecordingError("header: format version " + (version == j.end() ? "?" : version->dump()) +
                         "; this build reads version " + std::to_string(kFormatVersion));
  h.site = text_field(j, "site");
  h.unit = text_field(j, "unit");
  h.model = text_field(j, "model");
  const auto period = j.find("period_s");
  if (period == j.end() || !period->is_number() || !(period->get<double>() > 0.0))
    throw RecordingError("header: \"period_s\" is missing or not a positive number");
  h.period_s = period->get<double>();
  h.run_ns = integer_field<std::int64_t>(j, "run_ns");
  h.sequence = integer_field<std::uint64_t>(j, "sequence");
  const auto points = j.find("points");
  if (points == j.end() || !points->is_array() || points->size() > kMaxPoints)
    throw RecordingError("header: \"points\" is missing or not an array of at most 4096");
  for (const auto& p : *points) {
    if (!p.is_object()) throw RecordingError("header: a point is not an object");
    h.points.push_back({text_field(p, "name"), text_field(p, "unit"), text_field(p, "role")});
  }
  return h;
}

}  // namespace

RecordingHeader decode_header(std::span<const std::byte> json) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(reinterpret_cast<const char*>(json.data()),
                              reinterpret_cast<const char*>(json.data()) + json.size());
  } catch (const nlohmann::json::exception& e) {
    throw RecordingError(std::string("header: not JSON: ") + e.what());
  }
  // j.value() throws a type_error for a key of another type ("format": [], "run_ns": "x").
  try {
    return header_of(j);
  } catch (const nlohmann::json::exception& e) {
    throw RecordingError(std::string("header: ") + e.what());
  }
}

std::size_t encode_record(std::uint64_t cycle, std::uint64_t ticks_since_last,
                          std::int64_t timestamp_ns, bool connected,
                          std::span<const modbus::PointSample> samples,
                          std::int64_t now_monotonic_ns, std::span<std::byte> out) noexcept {
  const std::size_t size = record_size(samples.size());
  if (out.size() < size || samples.size() > kMaxPoints) return 0;
  std::byte* at = out.data() + kRecordPreambleBytes;
  put(at, cycle);
  put(at, ticks_since_last);
  put(at, timestamp_ns);
  put(at, static_cast<std::uint32_t>(samples.size()));
  put(at, static_cast<std::uint32_t>(connected ? 1u : 0u));  // flags byte and 3 zero bytes
  for (const auto& s : samples) {
    put(at, s.value);
    put(at, static_cast<std::uint8_t>(s.quality));
    put(at, s.exception_code);
    // A read that completed after the cycle took `now` (the poller's thread runs beside the
    // cycle) is as fresh as a reading can be: age 0. Written as it was, negative, it made the
    // record implausible to the decoder, and a replay of a loaded gateway's recording stopped
    // there (seen under CI load, 0.2 ms).
    put(at, s.read_time_ns == 0 ? std::int64_t{-1}
                                : std::max<std::int64_t>(0, now_monotonic_ns - s.read_time_ns));
  }
  const std::span<const std::byte> payload(out.data() + kRecordPreambleBytes,
                                           payload_size(samples.size()));
  std::byte* head = out.data();
  put(head, static_cast<std::uint32_t>(payload.size()));
  put(head, runtime::crc32c(payload));
  return size;
}

bool decode_payload(std::span<const std::byte> payload, RecordedCycle& out, std::string& why) {
  if (payload.size() < kCycleBytes) {
    why = "shorter than a cycle";
    return false;
  }
  const std::byte* at = payload.data();
  out.cycle = get<std::uint64_t>(at);
  out.ticks_since_last = get<std::uint64_t>(at);
  out.timestamp_ns = get<std::int64_t>(at);
  const auto points = get<std::uint32_t>(at);
  const auto flags = get<std::uint32_t>(at);
  if (payload.size() != payload_size(points)) {
    why = "its length does not match its " + std::to_string(points) + " points";
    return false;
  }
  if (out.ticks_since_last == 0 || (flags & ~1u) != 0) {
    why = "ticks since the last cycle 0, or unknown flags";
    return false;
  }
  out.connected = (flags & 1u) != 0;
  out.samples.resize(points);
  for (auto& s : out.samples) {
    s.value = get<double>(at);
    const auto quality = get<std::uint8_t>(at);
    s.exception_code = get<std::uint8_t>(at);
    // -1: never read. Below it: a read after the cycle's clock reading, as daemons before
    // encode_record() clamped it wrote (a fresh reading: the cycle's own time, below).
    const auto age = get<std::int64_t>(at);
    // An age beyond the timestamp's range would overflow timestamp - age (undefined behaviour).
    if (quality > static_cast<std::uint8_t>(modbus::PointQuality::kOutOfRange) ||
        (age > 0 && out.timestamp_ns < std::numeric_limits<std::int64_t>::min() + age)) {
      why = "a point's quality " + std::to_string(quality) + " or age " + std::to_string(age) +
            " is not valid";
      return false;
    }
    s.quality = static_cast<modbus::PointQuality>(quality);
    s.read_time_ns = age == -1 ? 0 : age < 0 ? out.timestamp_ns : out.timestamp_ns - age;
  }
  return true;
}

}  // namespace hvac_twin::recording
