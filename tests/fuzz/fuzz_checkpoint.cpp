// libFuzzer target: checkpoint loading (daemon/runtime/checkpoint.hpp). Input: the bytes of a
// state.ckpt file, given to decode_checkpoint() and validate_checkpoint() (no file system).
// Invariants: a rejected input says why; an accepted one has n in 1..cap, P n x n, x and P
// finite, P symmetric with a non-negative diagonal, and re-encodes to exactly the input bytes
// (the format is canonical: no field or padding the decoder ignores); it validates against an
// expectation made of itself and fails one that differs in the unit.
//
// Random mutations almost never keep a CRC valid, so most inputs would stop at the checksum:
// each input is also decoded "sealed", with its declared length and its trailer rewritten to
// match, so that the fuzzer explores the parsing and plausibility checks behind the checksum.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "daemon/runtime/checkpoint.hpp"
#include "tests/fuzz/fuzz_input.hpp"

namespace ckpt = hvac_twin::runtime;

namespace {

void check(std::span<const std::byte> bytes) {
  const ckpt::DecodedCheckpoint d = ckpt::decode_checkpoint(bytes);
  if (!d.ok()) {
    HVAC_TWIN_FUZZ_CHECK(!d.status.message.empty());
    return;
  }
  const ckpt::FilterSnapshot& s = d.snapshot;
  const std::size_t n = s.x.size();
  HVAC_TWIN_FUZZ_CHECK(n >= 1 && n <= ckpt::kCheckpointMaxStates);
  HVAC_TWIN_FUZZ_CHECK(s.P.size() == n * n);
  for (std::size_t r = 0; r < n; ++r) {
    HVAC_TWIN_FUZZ_CHECK(std::isfinite(s.x[r]));
    HVAC_TWIN_FUZZ_CHECK(s.P[r * n + r] >= 0.0);
    for (std::size_t c = 0; c < n; ++c)
      HVAC_TWIN_FUZZ_CHECK(std::isfinite(s.P[r * n + c]));
  }

  std::vector<std::byte> again(ckpt::checkpoint_size(s));
  HVAC_TWIN_FUZZ_CHECK(ckpt::encode_checkpoint(s, again) == bytes.size());
  for (std::size_t i = 0; i < bytes.size(); ++i)
    HVAC_TWIN_FUZZ_CHECK(again[i] == bytes[i]);

  ckpt::CheckpointExpectation e{.model_fingerprint = s.model_fingerprint,
                                .unit_id = s.unit_id,
                                .num_states = n,
                                .leak_block_size = s.leak_detector.size()};
  HVAC_TWIN_FUZZ_CHECK(ckpt::validate_checkpoint(s, e, s.wall_time_ns).ok());
  e.unit_id += "x";
  HVAC_TWIN_FUZZ_CHECK(ckpt::validate_checkpoint(s, e, 0).error ==
                       ckpt::CheckpointError::kWrongModel);
}

void put_le(std::vector<std::byte>& b, std::size_t offset, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i)
    b[offset + static_cast<std::size_t>(i)] = static_cast<std::byte>((v >> (8 * i)) & 0xFFU);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto bytes = std::as_bytes(std::span(data, size));
  check(bytes);
  constexpr std::size_t kLengthOffset = 16;
  if (size < ckpt::kCheckpointHeaderBytes + ckpt::kCheckpointTrailerBytes) return 0;
  std::vector<std::byte> sealed(bytes.begin(), bytes.end());
  put_le(sealed, kLengthOffset, size, 8);
  const std::size_t body = size - ckpt::kCheckpointTrailerBytes;
  put_le(sealed, body, ckpt::crc32c(std::span(sealed).first(body)), 4);
  check(sealed);
  return 0;
}
