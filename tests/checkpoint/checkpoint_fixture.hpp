// Shared by the checkpoint tests and the writer program: a deterministic snapshot per cycle
// (so a reader can tell a checkpoint's content belongs to its cycle), its expectation, and a
// temporary directory. Test code: allocates freely.
#pragma once

#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "daemon/runtime/checkpoint.hpp"

namespace hvac_twin::test {

inline constexpr std::size_t kLeakBlock = 3;

inline runtime::CheckpointExpectation checkpoint_expectation(std::size_t n) {
  plant::ModelLayout layout;
  for (std::size_t i = 0; i < n; ++i) {
    std::string name = "s";  // appended: GCC 12 -O2 warns falsely (-Wrestrict) on "s" + string
    name += std::to_string(i);
    layout.states.push_back(plant::StateInfo{.name = name});
  }
  return {.model_fingerprint = runtime::model_fingerprint("test_model", layout),
          .unit_id = "hp1",
          .num_states = n,
          .leak_block_size = kLeakBlock};
}

// Fills `s` (sized by the first call, refilled in place after) with the content of `cycle`:
// x_i = cycle + i/2, a symmetric, diagonally dominant P that changes with the cycle.
inline void fill_snapshot(runtime::FilterSnapshot& s, std::uint64_t cycle, std::size_t n) {
  if (s.x.size() != n) {
    const auto e = checkpoint_expectation(n);
    s.model_fingerprint = e.model_fingerprint;
    s.unit_id = e.unit_id;
    s.x.assign(n, 0.0);
    s.P.assign(n * n, 0.0);
    s.leak_detector.assign(kLeakBlock, 0.0);
  }
  const auto c = static_cast<double>(cycle);
  s.cycle = cycle;
  s.model_time_s = 60.0 * c;
  s.wall_time_ns = 1'700'000'000'000'000'000 + static_cast<std::int64_t>(cycle);
  for (std::size_t i = 0; i < n; ++i)
    s.x[i] = c + 0.5 * static_cast<double>(i);
  for (std::size_t r = 0; r < n; ++r)
    for (std::size_t q = 0; q < n; ++q)
      s.P[r * n + q] = r == q ? 1.0 + static_cast<double>(r) + 1e-3 * std::fmod(c, 1000.0)
                              : 0.01 / (1.0 + static_cast<double>(r + q));
  s.counters = {.predicts = cycle,
                .updates = cycle,
                .fused = 3 * cycle,
                .gate_rejections = cycle / 7,
                .predict_failures = 1,
                .numerical_resets = 2,
                .covariance_resets = 3,
                .constrained_updates = cycle / 2,
                .projection_failures = 4};
  s.leak_detector = {c, 0.25, -1.0};
  s.flags = 0x5u;
}

inline runtime::FilterSnapshot make_snapshot(std::uint64_t cycle, std::size_t n) {
  runtime::FilterSnapshot s;
  fill_snapshot(s, cycle, n);
  return s;
}

// True if `s` is exactly the snapshot fill_snapshot() makes for its own cycle.
inline bool is_snapshot_of_its_cycle(const runtime::FilterSnapshot& s) {
  const runtime::FilterSnapshot want = make_snapshot(s.cycle, s.x.size());
  const auto& a = s.counters;
  const auto& b = want.counters;
  return s.model_fingerprint == want.model_fingerprint && s.unit_id == want.unit_id &&
         s.model_time_s == want.model_time_s && s.wall_time_ns == want.wall_time_ns &&
         s.x == want.x && s.P == want.P && s.leak_detector == want.leak_detector &&
         s.flags == want.flags && a.predicts == b.predicts && a.updates == b.updates &&
         a.fused == b.fused && a.gate_rejections == b.gate_rejections &&
         a.predict_failures == b.predict_failures && a.numerical_resets == b.numerical_resets &&
         a.covariance_resets == b.covariance_resets &&
         a.constrained_updates == b.constrained_updates &&
         a.projection_failures == b.projection_failures;
}

inline std::vector<std::byte> encode(const runtime::FilterSnapshot& s) {
  std::vector<std::byte> bytes(runtime::checkpoint_size(s));
  bytes.resize(runtime::encode_checkpoint(s, bytes));
  return bytes;
}

inline std::vector<std::byte> read_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  const std::vector<char> chars((std::istreambuf_iterator<char>(in)),
                                std::istreambuf_iterator<char>());
  std::vector<std::byte> bytes(chars.size());
  for (std::size_t i = 0; i < chars.size(); ++i)
    bytes[i] = static_cast<std::byte>(chars[i]);
  return bytes;
}

inline void write_bytes(const std::filesystem::path& path, const std::vector<std::byte>& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

// A fresh directory under $TMPDIR (or /tmp), removed with everything in it at scope exit.
class TempDir {
 public:
  TempDir() {
    const char* base = std::getenv("TMPDIR");
    std::string pattern = std::string(base != nullptr ? base : "/tmp") + "/hvac-ckpt-XXXXXX";
    if (::mkdtemp(pattern.data()) != nullptr) path_ = pattern;
  }
  ~TempDir() {
    std::error_code ec;
    if (!path_.empty()) std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  [[nodiscard]] const std::filesystem::path& path() const { return path_; }
  [[nodiscard]] std::string str() const { return path_.string(); }

 private:
  std::filesystem::path path_;
};

}  // namespace hvac_twin::test
