// Shared by the recording tests: a unit's header, cycles of samples with every quality, and the
// bytes of files written or damaged by hand.
#pragma once

#include <spdlog/logger.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "daemon/recording/recording_format.hpp"
#include "daemon/runtime/checkpoint.hpp"

namespace hvac_twin::test {

inline recording::RecordingHeader recording_header(std::size_t points, std::string unit = "ahu-1") {
  recording::RecordingHeader h{.site = "plant-7",
                               .unit = std::move(unit),
                               .model = "heat_pump",
                               .period_s = 0.5,
                               .run_ns = 1'700'000'000'123'456'789,
                               .sequence = 7};
  for (std::size_t i = 0; i < points; ++i) {
    std::string name("p");  // not "p" + to_string(i): GCC 12 warns -Wrestrict on that, wrongly
    name += std::to_string(i);
    h.points.push_back({name, i % 2 == 0 ? "degC" : "kPa", i % 3 == 0 ? "input" : "measured"});
  }
  return h;
}

// One cycle's samples as the poller hands them over: read times on the monotonic clock, before
// `now`; every quality in turn, an exception code with kDeviceException, point 0 never read.
struct Cycle {
  std::uint64_t cycle = 0;
  std::uint64_t ticks_since_last = 1;
  std::int64_t timestamp_ns = 0;
  bool connected = true;
  std::int64_t now_ns = 0;  // monotonic
  std::vector<modbus::PointSample> samples;
};

inline Cycle make_cycle(std::uint64_t cycle, std::size_t points) {
  Cycle c{
      .cycle = cycle,
      .ticks_since_last = cycle % 3 == 0 ? 2u : 1u,
      .timestamp_ns = 1'700'000'000'000'000'000 + static_cast<std::int64_t>(cycle) * 500'000'000,
      .connected = cycle % 2 == 0,
      .now_ns = 9'000'000'000 + static_cast<std::int64_t>(cycle) * 500'000'000};
  for (std::size_t i = 0; i < points; ++i) {
    const auto quality = static_cast<modbus::PointQuality>((cycle + i) % 6);
    modbus::PointSample s{
        .value = 20.0 + static_cast<double>(i) / 7.0 + static_cast<double>(cycle) * 1e-3,
        .quality = quality,
        .exception_code = quality == modbus::PointQuality::kDeviceException
                              ? static_cast<std::uint8_t>(2 + i % 3)
                              : std::uint8_t{0},
        .read_time_ns = c.now_ns - 1'000 * static_cast<std::int64_t>(i + 1)};
    if (i == 0) s = {};  // never read
    c.samples.push_back(s);
  }
  return c;
}

inline std::vector<std::byte> encode(const Cycle& c) {
  std::vector<std::byte> out(recording::record_size(c.samples.size()));
  const std::size_t n = recording::encode_record(c.cycle, c.ticks_since_last, c.timestamp_ns,
                                                 c.connected, c.samples, c.now_ns, out);
  out.resize(n);
  return out;
}

inline void append(std::vector<std::byte>& to, std::span<const std::byte> bytes) {
  to.insert(to.end(), bytes.begin(), bytes.end());
}

inline void write_bytes(const std::string& path, std::span<const std::byte> bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

inline std::vector<std::byte> read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  const std::vector<char> chars((std::istreambuf_iterator<char>(in)),
                                std::istreambuf_iterator<char>());
  std::vector<std::byte> out(chars.size());
  if (!chars.empty()) std::memcpy(out.data(), chars.data(), chars.size());
  return out;
}

inline void put_u32(std::vector<std::byte>& b, std::size_t at, std::uint32_t v) {
  std::memcpy(b.data() + at, &v, sizeof v);
}

// Rewrites the CRC of the record at `at` to match its payload: a damage the checksum cannot see.
inline void reseal_record(std::vector<std::byte>& b, std::size_t at, std::size_t payload) {
  put_u32(b, at + 4, runtime::crc32c(std::span<const std::byte>(b).subspan(at + 8, payload)));
}

// A logger without sinks: the recorder's messages go nowhere.
inline std::shared_ptr<spdlog::logger> quiet_logger() {
  return std::make_shared<spdlog::logger>("recording-test");
}

}  // namespace hvac_twin::test
