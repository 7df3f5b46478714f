#include "daemon/runtime/checkpoint.hpp"

#include <array>
#include <bit>
#include <utility>

namespace hvac_twin::runtime {
namespace {

constexpr std::array<std::uint32_t, 256> make_crc_table() {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k)
      c = (c & 1U) != 0 ? 0x82F63B78U ^ (c >> 1) : c >> 1;
    table[i] = c;
  }
  return table;
}
constexpr std::array<std::uint32_t, 256> kCrcTable = make_crc_table();

// Little-endian writer over a buffer whose size was checked beforehand.
class Writer {
 public:
  explicit Writer(std::span<std::byte> out) : out_(out) {}
  void u32(std::uint32_t v) { put(v, 4); }
  void u64(std::uint64_t v) { put(v, 8); }
  void f64(double v) { put(std::bit_cast<std::uint64_t>(v), 8); }
  void text(std::string_view s) {
    for (const char c : s)
      out_[pos_++] = static_cast<std::byte>(c);
  }
  [[nodiscard]] std::size_t pos() const { return pos_; }

 private:
  void put(std::uint64_t v, int bytes) {
    for (int i = 0; i < bytes; ++i)
      out_[pos_++] = static_cast<std::byte>((v >> (8 * i)) & 0xFFU);
  }
  std::span<std::byte> out_;
  std::size_t pos_ = 0;
};

}  // namespace

std::string model_fingerprint(std::string_view model_type, const plant::ModelLayout& layout) {
  std::string f(model_type);
  f += ':';
  for (std::size_t i = 0; i < layout.states.size(); ++i) {
    if (i > 0) f += ',';
    f += layout.states[i].name;
  }
  return f;
}

CheckpointExpectation make_checkpoint_expectation(std::string_view model_type,
                                                  const plant::ModelLayout& layout,
                                                  std::string unit_id, std::size_t leak_block_size,
                                                  std::int64_t max_age_ns) {
  CheckpointExpectation e{.model_fingerprint = model_fingerprint(model_type, layout),
                          .unit_id = std::move(unit_id),
                          .num_states = layout.states.size(),
                          .leak_block_size = leak_block_size,
                          .max_age_ns = max_age_ns};
  for (const plant::StateInfo& state : layout.states) {
    e.state_min.push_back(state.min);
    e.state_max.push_back(state.max);
  }
  return e;
}

std::size_t checkpoint_size(std::size_t n, std::size_t fingerprint_bytes, std::size_t unit_id_bytes,
                            std::size_t leak_block_size) {
  if (n > kCheckpointMaxStates || fingerprint_bytes > kCheckpointMaxText ||
      unit_id_bytes > kCheckpointMaxText || leak_block_size > kCheckpointMaxLeakBlock)
    return 0;
  return kCheckpointHeaderBytes + fingerprint_bytes + unit_id_bytes + 8 * kCheckpointCounters +
         8 * (n + n * n + leak_block_size) + kCheckpointTrailerBytes;
}

std::size_t checkpoint_size(const FilterSnapshot& s) {
  return checkpoint_size(s.x.size(), s.model_fingerprint.size(), s.unit_id.size(),
                         s.leak_detector.size());
}

std::uint32_t crc32c(std::span<const std::byte> bytes) {
  std::uint32_t c = 0xFFFFFFFFU;
  for (const std::byte b : bytes)
    c = kCrcTable[(c ^ static_cast<std::uint32_t>(b)) & 0xFFU] ^ (c >> 8);
  return ~c;
}

std::string_view to_string(CheckpointError error) {
  switch (error) {
    case CheckpointError::kNone:
      return "ok";
    case CheckpointError::kTruncated:
      return "truncated";
    case CheckpointError::kBadMagic:
      return "bad magic";
    case CheckpointError::kWrongVersion:
      return "wrong version";
    case CheckpointError::kBadChecksum:
      return "bad checksum";
    case CheckpointError::kImplausible:
      return "implausible";
    case CheckpointError::kWrongModel:
      return "wrong model";
    case CheckpointError::kStale:
      return "stale";
  }
  return "unknown";
}

std::size_t encode_checkpoint(const FilterSnapshot& s, std::span<std::byte> out) {
  const std::size_t n = s.x.size();
  const std::size_t size = checkpoint_size(s);
  if (size == 0 || out.size() < size || s.P.size() != n * n) return 0;
  Writer w(out);
  w.text(kCheckpointMagic);
  w.u32(kCheckpointFormatVersion);
  w.u32(static_cast<std::uint32_t>(kCheckpointHeaderBytes));
  w.u64(size);
  w.u64(s.cycle);
  w.f64(s.model_time_s);
  w.u64(static_cast<std::uint64_t>(s.wall_time_ns));
  w.u32(s.flags);
  w.u32(static_cast<std::uint32_t>(n));
  w.u32(static_cast<std::uint32_t>(s.model_fingerprint.size()));
  w.u32(static_cast<std::uint32_t>(s.unit_id.size()));
  w.u32(static_cast<std::uint32_t>(s.leak_detector.size()));
  w.u32(static_cast<std::uint32_t>(kCheckpointCounters));
  w.text(s.model_fingerprint);
  w.text(s.unit_id);
  const est::EstimatorCounters& k = s.counters;
  for (const std::uint64_t v :
       {k.predicts, k.updates, k.fused, k.gate_rejections, k.predict_failures, k.numerical_resets,
        k.covariance_resets, k.constrained_updates, k.projection_failures})
    w.u64(v);
  for (const double v : s.x)
    w.f64(v);
  for (const double v : s.P)
    w.f64(v);
  for (const double v : s.leak_detector)
    w.f64(v);
  w.u32(crc32c(out.first(w.pos())));
  return w.pos();
}

}  // namespace hvac_twin::runtime
