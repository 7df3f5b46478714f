// The checkpoint of one unit's whole filter state, and its binary file format.
//
// Format version 1, every integer little-endian and every double as its IEEE-754 bits in a
// little-endian u64, written field by field (never a memcpy of a struct, so the file does not
// depend on the compiler's padding or the host's byte order):
//
//   offset  field
//        0  magic "HVTWCKPT" (8 bytes)
//        8  u32 format version (1)
//       12  u32 header length (72 for version 1)
//       16  u64 total file length, trailer included
//       24  u64 cycle counter (the generation: increases with every checkpoint of a run)
//       32  f64 model time [s]
//       40  i64 wall time of writing [ns since the epoch, CLOCK_REALTIME]
//       48  u32 flags (reserved, stored verbatim)
//       52  u32 n, number of states
//       56  u32 fingerprint length [bytes]
//       60  u32 unit id length [bytes]
//       64  u32 leak-detector block length [doubles]
//       68  u32 number of counters (9 for version 1)
//       72  fingerprint, unit id, counters (u64 each), x (n f64), P (n x n f64, row-major),
//           leak-detector block
//  total-4  u32 CRC-32C of every byte before it
//
// Decoding is a pure function of the bytes (what the fuzz target calls); whether a decoded
// checkpoint belongs to this unit and model is a separate check (validate_checkpoint), and the
// file handling is in checkpoint_store.hpp.
//
// Allocation: encode_checkpoint() writes into a caller-provided buffer and allocates nothing;
// decode_checkpoint() and validate_checkpoint() allocate (start-up only). Nothing throws. Any
// thread; no shared state.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "daemon/estimation/estimator.hpp"
#include "plant_models/core/model_info.hpp"

namespace hvac_twin::runtime {

inline constexpr std::string_view kCheckpointMagic = "HVTWCKPT";
inline constexpr std::uint32_t kCheckpointFormatVersion = 1;
inline constexpr std::size_t kCheckpointHeaderBytes = 72;
inline constexpr std::size_t kCheckpointTrailerBytes = 4;
inline constexpr std::size_t kCheckpointCounters = 9;  // fields of est::EstimatorCounters
// Caps a decoder enforces before trusting any length (so a corrupt length cannot make it
// allocate gigabytes): far above the largest model (the heat pump at 40 cells per exchanger).
inline constexpr std::size_t kCheckpointMaxStates = 1024;
inline constexpr std::size_t kCheckpointMaxText = 65536;       // fingerprint, unit id [bytes]
inline constexpr std::size_t kCheckpointMaxLeakBlock = 65536;  // [doubles]

// FilterSnapshot::flags: the filter was still converging (flag cold_start) when saved, so the
// resumed one is too until it converges.
inline constexpr std::uint32_t kSnapshotConverging = 1u << 0;
// FilterSnapshot::flags: the augmented states were held or not yet at full gain when saved (the
// parameter hold and release of a cold start), so the resumed filter ramps them in again.
inline constexpr std::uint32_t kSnapshotReleasing = 1u << 1;

// Everything a restarted daemon needs to continue one unit's estimate. Plain data; the runtime
// keeps one, sized at start-up, and refills it in place (no allocation once sized).
struct FilterSnapshot {
  std::string model_fingerprint;  // model_fingerprint(): which model and state layout
  std::string unit_id;
  std::uint64_t cycle = 0;
  double model_time_s = 0.0;      // [s]
  std::int64_t wall_time_ns = 0;  // CLOCK_REALTIME when written [ns since the epoch]
  std::vector<double> x;          // n states
  std::vector<double> P;          // n x n covariance, row-major
  est::EstimatorCounters counters;
  std::vector<double> leak_detector;  // the leak detector's own saved state, stored verbatim
  std::uint32_t flags = 0;            // kSnapshot* bits; others reserved, stored verbatim
};

// "<model type>:<state name>,<state name>,...": a checkpoint of another model, another cell
// count or a reordered state vector does not match. Allocates.
std::string model_fingerprint(std::string_view model_type, const plant::ModelLayout& layout);

// Size of the encoded checkpoint [bytes]; 0 if a length is over its cap.
std::size_t checkpoint_size(std::size_t num_states, std::size_t fingerprint_bytes,
                            std::size_t unit_id_bytes, std::size_t leak_block_size);
std::size_t checkpoint_size(const FilterSnapshot& snapshot);

// Encodes into `out`; returns the bytes written, or 0 (out untouched beyond what it wrote) if
// out is smaller than checkpoint_size(snapshot), P is not n x n, or a length is over its cap.
// Values are not judged here: decode_checkpoint() does. No allocation.
std::size_t encode_checkpoint(const FilterSnapshot& snapshot, std::span<std::byte> out);

// CRC-32C (Castagnoli, as iSCSI and ext4 metadata use), reflected, initial and final xor ~0.
std::uint32_t crc32c(std::span<const std::byte> bytes);

enum class CheckpointError : std::uint8_t {
  kNone,
  kTruncated,     // shorter than its header or its declared length
  kBadMagic,      // not a checkpoint
  kWrongVersion,  // a format version this build cannot read
  kBadChecksum,   // CRC-32C mismatch: torn or corrupted
  kImplausible,   // checksum fine, content not: lengths, non-finite values, P not a covariance
  kWrongModel,    // another model, state layout, unit or leak-detector block size
  kStale,         // written longer ago (or further ahead) than the maximum age allows
};
std::string_view to_string(CheckpointError error);

struct CheckpointStatus {
  CheckpointError error = CheckpointError::kNone;
  std::string message;  // what exactly was wrong, for the log
  [[nodiscard]] bool ok() const { return error == CheckpointError::kNone; }
};

struct DecodedCheckpoint {
  CheckpointStatus status;
  FilterSnapshot snapshot;  // meaningful only when status.ok()
  [[nodiscard]] bool ok() const { return status.ok(); }
};

// Relative tolerance of the symmetry test on P, |Pij - Pji| <= tol · max(|Pij|, |Pji|), and
// of the correlation bound |Pij| <= (1 + tol) √(Pii Pjj).
inline constexpr double kCheckpointSymmetryTolerance = 1e-9;

// Parses and checks the bytes of a checkpoint file: header, lengths, checksum, then
// plausibility (n in 1..cap, x and P finite, P symmetric, variances >= 0, correlations within
// [-1, 1], model time finite, wall time >= 0). Never reads outside `bytes`.
DecodedCheckpoint decode_checkpoint(std::span<const std::byte> bytes);

// What the daemon expects of its unit's checkpoint.
struct CheckpointExpectation {
  std::string model_fingerprint;
  std::string unit_id;
  std::size_t num_states = 0;
  std::size_t leak_block_size = 0;  // [doubles]
  std::int64_t max_age_ns = 0;      // 0: any age
  // The states' physical bounds (plant::StateInfo min, max; empty: not checked).
  std::vector<double> state_min, state_max;
};

// The expectation for a unit running `model_type` with `layout`: fingerprint, n and bounds.
CheckpointExpectation make_checkpoint_expectation(std::string_view model_type,
                                                  const plant::ModelLayout& layout,
                                                  std::string unit_id, std::size_t leak_block_size,
                                                  std::int64_t max_age_ns = 0);

// kWrongModel if fingerprint, unit id, n or the leak block size differ; kImplausible if a state
// lies outside its bounds by more than a quarter of its range (of the finite bound's magnitude,
// at least 1, for a half-open range), a margin that lets an unconstrained filter's excursions
// restore but not a value no filter could reach; kStale if max_age_ns > 0 and |now - wall time|
// exceeds it (a clock set back counts as well as an old file).
CheckpointStatus validate_checkpoint(const FilterSnapshot& snapshot,
                                     const CheckpointExpectation& expected,
                                     std::int64_t now_realtime_ns);

}  // namespace hvac_twin::runtime
