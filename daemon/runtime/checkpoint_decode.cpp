// Decoding and checking of checkpoint files (format in checkpoint.hpp). Every length is checked
// against its cap and against the bytes present before any field behind it is read.
#include <algorithm>
#include <bit>
#include <cmath>
#include <string>
#include <utility>

#include "daemon/runtime/checkpoint.hpp"

namespace hvac_twin::runtime {
namespace {

// Little-endian reader; the caller has checked that every read stays inside the span.
class Reader {
 public:
  explicit Reader(std::span<const std::byte> in, std::size_t pos = 0) : in_(in), pos_(pos) {}
  std::uint32_t u32() { return static_cast<std::uint32_t>(get(4)); }
  std::uint64_t u64() { return get(8); }
  double f64() { return std::bit_cast<double>(get(8)); }
  std::string text(std::size_t n) {
    std::string s(n, '\0');
    for (std::size_t i = 0; i < n; ++i)
      s[i] = static_cast<char>(in_[pos_++]);
    return s;
  }

 private:
  std::uint64_t get(int bytes) {
    std::uint64_t v = 0;
    for (int i = 0; i < bytes; ++i)
      v |= static_cast<std::uint64_t>(in_[pos_++]) << (8 * i);
    return v;
  }
  std::span<const std::byte> in_;
  std::size_t pos_;
};

CheckpointStatus fail(CheckpointError e, std::string message) {
  return CheckpointStatus{e, std::move(message)};
}

std::string element(const char* name, std::size_t r, std::size_t c, double v) {
  return std::string(name) + "(" + std::to_string(r) + "," + std::to_string(c) +
         ") = " + std::to_string(v);
}

// The plausibility of decoded content (the checksum has passed: a bug or a tampered file).
CheckpointStatus plausible(const FilterSnapshot& s) {
  const std::size_t n = s.x.size();
  if (!std::isfinite(s.model_time_s))
    return fail(CheckpointError::kImplausible, "model time is not finite");
  if (s.wall_time_ns < 0) return fail(CheckpointError::kImplausible, "wall time before 1970");
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(s.x[i]))
      return fail(CheckpointError::kImplausible, "x[" + std::to_string(i) + "] is not finite");
  for (std::size_t r = 0; r < n; ++r) {
    const double prr = s.P[r * n + r];
    if (!std::isfinite(prr)) return fail(CheckpointError::kImplausible, element("P", r, r, prr));
    if (prr < 0.0)
      return fail(CheckpointError::kImplausible, "negative variance " + element("P", r, r, prr));
  }
  const double tol = kCheckpointSymmetryTolerance;
  for (std::size_t r = 0; r < n; ++r) {
    for (std::size_t c = 0; c < r; ++c) {
      const double a = s.P[r * n + c], b = s.P[c * n + r];
      if (!std::isfinite(a) || !std::isfinite(b))
        return fail(CheckpointError::kImplausible,
                    "non-finite " + element("P", r, c, a) + ", " + element("P", c, r, b));
      if (!(std::abs(a - b) <= tol * std::max(std::abs(a), std::abs(b))))
        return fail(CheckpointError::kImplausible,
                    "P not symmetric: " + element("P", r, c, a) + ", " + element("P", c, r, b));
      // A necessary condition of positive semi-definiteness that costs nothing more.
      const double bound = std::sqrt(s.P[r * n + r] * s.P[c * n + c]);
      if (!(std::abs(a) <= (1.0 + tol) * bound))
        return fail(CheckpointError::kImplausible,
                    "correlation outside [-1, 1] at " + element("P", r, c, a));
    }
  }
  return {};
}

}  // namespace

DecodedCheckpoint decode_checkpoint(std::span<const std::byte> bytes) {
  DecodedCheckpoint out;
  const std::size_t size = bytes.size();
  const auto status = [&](CheckpointError e, std::string message) {
    out.status = fail(e, std::move(message));
    return out;
  };
  const std::string have = std::to_string(size) + " bytes";
  if (size < kCheckpointMagic.size())
    return status(CheckpointError::kTruncated, have + ", shorter than the magic");
  for (std::size_t i = 0; i < kCheckpointMagic.size(); ++i)
    if (bytes[i] != static_cast<std::byte>(kCheckpointMagic[i]))
      return status(CheckpointError::kBadMagic, "not a checkpoint (magic differs)");
  if (size < 16) return status(CheckpointError::kTruncated, have + ", shorter than the version");
  Reader head(bytes, kCheckpointMagic.size());
  const std::uint32_t version = head.u32();
  if (version != kCheckpointFormatVersion)
    return status(CheckpointError::kWrongVersion, "format version " + std::to_string(version) +
                                                      ", this build reads " +
                                                      std::to_string(kCheckpointFormatVersion));
  const std::uint32_t header_bytes = head.u32();
  if (header_bytes != kCheckpointHeaderBytes)
    return status(CheckpointError::kImplausible,
                  "header length " + std::to_string(header_bytes) + " for version 1");
  if (size < kCheckpointHeaderBytes + kCheckpointTrailerBytes)
    return status(CheckpointError::kTruncated, have + ", shorter than the header");
  const std::uint64_t total = head.u64();
  const std::size_t largest = checkpoint_size(kCheckpointMaxStates, kCheckpointMaxText,
                                              kCheckpointMaxText, kCheckpointMaxLeakBlock);
  if (total < kCheckpointHeaderBytes + kCheckpointTrailerBytes || total > largest)
    return status(CheckpointError::kImplausible,
                  "declared length " + std::to_string(total) + " out of range");
  if (size < total)
    return status(CheckpointError::kTruncated, have + " of " + std::to_string(total));
  if (size > total)
    return status(CheckpointError::kImplausible,
                  have + ", " + std::to_string(size - total) + " past the declared length");
  const std::size_t body = total - kCheckpointTrailerBytes;
  const std::uint32_t stored = Reader(bytes, body).u32();
  const std::uint32_t computed = crc32c(bytes.first(body));
  if (stored != computed) return status(CheckpointError::kBadChecksum, "CRC-32C mismatch");

  FilterSnapshot& s = out.snapshot;
  s.cycle = head.u64();
  s.model_time_s = head.f64();
  s.wall_time_ns = static_cast<std::int64_t>(head.u64());
  s.flags = head.u32();
  const std::size_t n = head.u32(), fingerprint = head.u32(), unit = head.u32(), leak = head.u32(),
                    counters = head.u32();
  if (n == 0 || n > kCheckpointMaxStates)
    return status(CheckpointError::kImplausible, "n = " + std::to_string(n));
  if (counters != kCheckpointCounters)
    return status(CheckpointError::kImplausible, std::to_string(counters) + " counters");
  const std::size_t expected = checkpoint_size(n, fingerprint, unit, leak);
  if (expected != total)
    return status(CheckpointError::kImplausible,
                  "lengths inconsistent: fields need " + std::to_string(expected) +
                      " bytes, header declares " + std::to_string(total));
  s.model_fingerprint = head.text(fingerprint);
  s.unit_id = head.text(unit);
  est::EstimatorCounters& k = s.counters;
  for (std::uint64_t* v :
       {&k.predicts, &k.updates, &k.fused, &k.gate_rejections, &k.predict_failures,
        &k.numerical_resets, &k.covariance_resets, &k.constrained_updates, &k.projection_failures})
    *v = head.u64();
  s.x.resize(n);
  for (double& v : s.x)
    v = head.f64();
  s.P.resize(n * n);
  for (double& v : s.P)
    v = head.f64();
  s.leak_detector.resize(leak);
  for (double& v : s.leak_detector)
    v = head.f64();
  out.status = plausible(s);
  return out;
}

CheckpointStatus validate_checkpoint(const FilterSnapshot& s, const CheckpointExpectation& e,
                                     std::int64_t now_realtime_ns) {
  if (s.model_fingerprint != e.model_fingerprint)
    return fail(CheckpointError::kWrongModel, "model fingerprint differs: checkpoint \"" +
                                                  s.model_fingerprint.substr(0, 120) + "\"");
  if (s.unit_id != e.unit_id)
    return fail(CheckpointError::kWrongModel, "unit \"" + s.unit_id.substr(0, 120) + "\"");
  if (s.x.size() != e.num_states || s.P.size() != e.num_states * e.num_states)
    return fail(CheckpointError::kWrongModel,
                std::to_string(s.x.size()) + " states, expected " + std::to_string(e.num_states));
  if (s.leak_detector.size() != e.leak_block_size)
    return fail(CheckpointError::kWrongModel,
                "leak-detector block of " + std::to_string(s.leak_detector.size()) +
                    " values, expected " + std::to_string(e.leak_block_size));
  for (std::size_t i = 0; i < e.state_min.size() && i < e.state_max.size() && i < s.x.size(); ++i) {
    const double lo = e.state_min[i], hi = e.state_max[i];
    const double range = hi - lo;
    const double margin =
        0.25 * (std::isfinite(range)
                    ? range
                    : std::max(1.0, std::isfinite(lo) ? std::abs(lo)
                                                      : (std::isfinite(hi) ? std::abs(hi) : 0.0)));
    if (s.x[i] < lo - margin || s.x[i] > hi + margin)
      return fail(CheckpointError::kImplausible,
                  "x[" + std::to_string(i) + "] = " + std::to_string(s.x[i]) +
                      " far outside the state's bounds [" + std::to_string(lo) + ", " +
                      std::to_string(hi) + "]");
  }
  if (e.max_age_ns > 0) {
    // In double: the difference of two arbitrary int64 cannot overflow, and 0.3 µs of rounding
    // at today's epoch does not matter against an age limit.
    const double age = static_cast<double>(now_realtime_ns) - static_cast<double>(s.wall_time_ns);
    if (std::abs(age) > static_cast<double>(e.max_age_ns))
      return fail(CheckpointError::kStale, "written " + std::to_string(age * 1e-9) +
                                               " s before now, more than the maximum age");
  }
  return {};
}

}  // namespace hvac_twin::runtime
