// Plain C++ views of the hvac-twin DDS wire types (io/dds/idl/hvac_twin.idl). The rest of the
// daemon fills these and hands them to UnitPublisher; it never sees a Cyclone DDS header.
//
// Units: every double carries the engineering unit named in its comment; timestamps are
// CLOCK_REALTIME nanoseconds since the Unix epoch.
// Ownership: the string_view fields are borrowed for the duration of one publish() call only;
// publish() copies them into fixed-size wire buffers and keeps no reference.
// Threads / allocation: plain aggregates; no allocation, no locking.
#pragma once

#include <cstddef>
#include <cstdint>
#include <iterator>
#include <span>
#include <string>
#include <string_view>

namespace hvac_twin::dds {

// The six topics. Their names are "<topic_prefix>/<topic_suffix>", e.g.
// "hvac_twin/virtual_sensor" ('/' is legal in Cyclone DDS 0.10 topic names).
enum class Topic : std::uint8_t {
  kVirtualSensor = 0,
  kObservation = 1,
  kEstimatorHealth = 2,
  kLeakDiagnostic = 3,
  kEstimatorConsistency = 4,
  kUnitEstimate = 5,
};
inline constexpr Topic kAllTopics[] = {Topic::kVirtualSensor,        Topic::kObservation,
                                       Topic::kEstimatorHealth,      Topic::kLeakDiagnostic,
                                       Topic::kEstimatorConsistency, Topic::kUnitEstimate};
inline constexpr std::size_t kNumTopics = std::size(kAllTopics);
// "virtual_sensor", "observation", "estimator_health", "leak_diagnostic",
// "estimator_consistency", "unit_estimate". Never allocates.
std::string_view topic_suffix(Topic topic) noexcept;
// "<prefix>/<suffix>". Throws std::invalid_argument unless prefix matches [A-Za-z0-9_]+ (the
// DdsConfig::topic_prefix rule). Allocates; creation time only.
std::string topic_name(std::string_view prefix, Topic topic);

// Longest accepted string per field, in bytes (the IDL bounds). A longer name is rejected, never
// truncated. Only EstimatorHealth.modbus_last_error, free text, is cut and marked with "...".
inline constexpr std::size_t kMaxNameLength = 64;        // site, unit, name, point
inline constexpr std::size_t kMaxEngUnitLength = 32;     // VirtualSensor.eng_unit
inline constexpr std::size_t kMaxErrorTextLength = 128;  // EstimatorHealth.modbus_last_error

// Quality of an estimate or of a unit's estimator. Values match IDL EstimateQuality.
enum class EstimateQuality : std::uint8_t { kGood = 0, kDegraded = 1, kNotReady = 2 };

// Quality of a measured Modbus point. Values match IDL PointQuality.
enum class PointQuality : std::uint8_t {
  kNotYetRead = 0,
  kGood = 1,
  kStale = 2,
  kCommFail = 3,
  kDeviceException = 4,
  kOutOfRange = 5,
  kStuck = 6,  // read GOOD, but frozen while the model says it should move: not fused
};

// VirtualSensorSample::flags, provenance bits (IDL VS_FLAG_*).
inline constexpr std::uint32_t kFlagPredictOnly = 1u << 0;       // no measurement fused
inline constexpr std::uint32_t kFlagConstraintActive = 1u << 1;  // constrained update at a bound
inline constexpr std::uint32_t kFlagInputHeld = 1u << 2;         // a stale input was held
inline constexpr std::uint32_t kFlagColdStart = 1u << 3;         // fresh start, converging
inline constexpr std::uint32_t kFlagNumericalReset = 1u << 4;    // x, P reset this cycle
inline constexpr std::uint32_t kFlagDeadlineOverrun = 1u << 5;   // this cycle overran
inline constexpr std::uint32_t kFlagLostTrack = 1u << 6;         // most measured points gated out

// One virtual sensor of the unit the publisher belongs to (site and unit come from it).
struct VirtualSensorSample {
  std::string_view name;      // key; 1..64 bytes, no NUL, e.g. "condenser_pressure"
  double value = 0.0;         // [eng_unit]; must be finite
  double sigma = 0.0;         // 1-sigma standard deviation [eng_unit]; finite and >= 0
  std::string_view eng_unit;  // 0..32 bytes, e.g. "Pa", "degC"
  EstimateQuality quality = EstimateQuality::kNotReady;
  std::uint32_t flags = 0;         // kFlag* bits
  std::uint64_t fused_points = 0;  // bit i: the unit's i-th measured point was fused
  std::int64_t timestamp_ns = 0;   // CLOCK_REALTIME [ns], >= 0; also the DDS source timestamp
  std::uint64_t cycle = 0;         // estimator cycle counter
};

// The most virtual sensors one UnitEstimateSample carries (IDL UNIT_ESTIMATE_MAX).
inline constexpr std::size_t kMaxUnitEstimates = 64;

// One model output in a UnitEstimateSample, as its VirtualSensorSample.
struct EstimateEntry {
  std::string_view name;      // 1..64 bytes, no NUL
  double value = 0.0;         // [eng_unit]; must be finite
  double sigma = 0.0;         // [eng_unit]; finite and >= 0
  std::string_view eng_unit;  // 0..32 bytes
};

// Every virtual sensor of the publisher's unit from one cycle, in one sample. A sample with an
// invalid entry is refused whole (the entry's reason); more than kMaxUnitEstimates entries is
// kInvalidValue.
struct UnitEstimateSample {
  std::span<const EstimateEntry> estimates;  // in the model's output order
  EstimateQuality quality = EstimateQuality::kNotReady;
  std::uint32_t flags = 0;         // kFlag* bits
  std::uint64_t fused_points = 0;  // bit i: the unit's i-th measured point was fused
  std::int64_t timestamp_ns = 0;   // CLOCK_REALTIME [ns], >= 0; also the DDS source timestamp
  std::uint64_t cycle = 0;
};

// One measured point in one cycle. Every double must be finite: for a point that was not read
// or not fused, publish value/predicted/innovation... as 0 (or the last value) and let quality
// and fused say so; a NaN is refused.
struct ObservationSample {
  std::string_view point;  // key; 1..64 bytes, no NUL; the configured point name
  double value = 0.0;      // measured value [point unit]
  PointQuality quality = PointQuality::kNotYetRead;
  std::uint8_t exception_code = 0;   // Modbus exception code if kDeviceException, else 0
  double predicted = 0.0;            // h(x-) [point unit]
  double innovation = 0.0;           // value - predicted [point unit]
  double innovation_variance = 0.0;  // S [point unit^2], >= 0
  double test_ratio = 0.0;           // NIS = innovation^2 / S [-], >= 0
  bool fused = false;                // the update used this measurement
  std::int64_t timestamp_ns = 0;     // CLOCK_REALTIME [ns], >= 0
  std::uint64_t cycle = 0;
};

// Health of the publisher's unit, published once per cycle. Counters count since start.
// publish_rejections on the wire is filled by the publisher itself (PublisherStats::rejected()).
struct HealthSample {
  std::uint64_t cycle = 0;
  double cycle_time_ms = 0.0;      // wall time of the last cycle [ms]; finite, >= 0
  double cycle_time_max_ms = 0.0;  // longest cycle since start [ms]; finite, >= 0
  std::uint64_t overruns = 0;
  std::uint64_t degraded_cycles = 0;
  std::uint64_t gate_rejections = 0;
  std::uint64_t numerical_resets = 0;
  EstimateQuality quality = EstimateQuality::kNotReady;
  bool modbus_connected = false;
  std::uint64_t modbus_polls_ok = 0;         // every request answered with data
  std::uint64_t modbus_polls_exception = 0;  // answered, some request with an exception
  std::uint64_t modbus_polls_failed = 0;     // transport or gateway failure, device down
  std::uint64_t modbus_reconnects = 0;
  std::string_view modbus_last_error;  // empty if none; cut to 128 bytes ending in "..."
  std::int64_t timestamp_ns = 0;       // CLOCK_REALTIME [ns], >= 0
};

// Leak alarm state and why the detector is holding. Values match IDL LeakState / LeakHold.
enum class LeakState : std::uint8_t { kNormal = 0, kSuspect = 1, kLeak = 2 };
enum class LeakHold : std::uint8_t {
  kNone = 0,
  kWarmUp = 1,
  kCompressorOff = 2,
  kStartUp = 3,
  kCycling = 4,
  kDegraded = 5,
};

// The refrigerant charge and leak diagnosis of the publisher's unit, published every cycle.
// Every double must be finite; sigmas, leak_rate, CUSUMs, the reference, thresholds and
// intervals >= 0.
struct LeakDiagnosticSample {
  LeakState state = LeakState::kNormal;
  LeakHold hold = LeakHold::kWarmUp;
  double charge = 0.0;            // [kg]
  double charge_sigma = 0.0;      // [kg]
  double nameplate_charge = 0.0;  // [kg]
  double leak_rate = 0.0;         // [g/h]
  double leak_rate_sigma = 0.0;   // [g/h]
  double cusum = 0.0;             // max(rate_cusum, charge_cusum) [sigma units]
  double rate_cusum = 0.0;        // on the leak-rate estimate [sigma units]
  double charge_cusum = 0.0;      // on the charge deficit [sigma units]
  double charge_reference = 0.0;  // [kg], 0: none (being learnt, or a speed band never seen)
  double threshold = 0.0;         // [sigma units]
  double false_alarm_interval_days = 0.0;
  std::uint64_t decisions = 0;
  std::int64_t suspect_since_ns = 0;  // CLOCK_REALTIME, 0: not in a SUSPECT/LEAK episode
  std::int64_t leak_since_ns = 0;     // CLOCK_REALTIME, 0: no LEAK in this episode
  EstimateQuality quality = EstimateQuality::kNotReady;
  std::int64_t timestamp_ns = 0;  // CLOCK_REALTIME [ns], >= 0
  std::uint64_t cycle = 0;
};

// Verdict of the consistency monitor. Values match IDL ConsistencyVerdict.
enum class ConsistencyVerdict : std::uint8_t {
  kInsufficientData = 0,
  kInBand = 1,
  kHigh = 2,  // sigmas too small
  kLow = 3,   // sigmas too large
};

// EstimatorConsistency.point of the figure pooled over all measured points. Point names are
// [A-Za-z0-9_]+ (configuration), so it is never a point's.
inline constexpr std::string_view kAllPoints = "*";

// The consistency of the publisher's unit's filter over a window, for one measured point or all
// (kAllPoints). Doubles finite and >= 0, rejected_share <= 1.
struct ConsistencySample {
  std::string_view point;           // key; 1..64 bytes, no NUL; a point name or kAllPoints
  std::uint32_t window_cycles = 0;  // the window [cycles]
  std::uint32_t samples = 0;        // NIS samples in the window
  double mean_nis = 0.0;            // [-], 0 without samples
  double band_low = 0.0;            // chi2_0.025(samples) / samples [-]
  double band_high = 0.0;           // chi2_0.975(samples) / samples [-]
  ConsistencyVerdict verdict = ConsistencyVerdict::kInsufficientData;
  double rejected_share = 0.0;    // [0, 1]
  std::int64_t timestamp_ns = 0;  // CLOCK_REALTIME [ns], >= 0
  std::uint64_t cycle = 0;
};

// Names used on the console and in JSON: the IDL enumerator without its prefix ("GOOD",
// "NOT_READY", "COMM_FAIL", ...).
// Out-of-range values (e.g. from a newer peer) give "UNKNOWN". Never allocates.
std::string_view to_string(EstimateQuality quality) noexcept;
std::string_view to_string(PointQuality quality) noexcept;
std::string_view to_string(LeakState state) noexcept;  // "NORMAL", "SUSPECT", "LEAK"
std::string_view to_string(LeakHold hold) noexcept;    // "NONE", "WARM_UP", "COMPRESSOR_OFF", ...
// "INSUFFICIENT_DATA", "IN_BAND", "HIGH", "LOW".
std::string_view to_string(ConsistencyVerdict verdict) noexcept;
// Name of one kFlag* bit ("predict_only", ...), or "" if the bit is not defined.
std::string_view flag_name(std::uint32_t single_bit) noexcept;

}  // namespace hvac_twin::dds
