#include "io/dds/types.hpp"

#include <stdexcept>

namespace hvac_twin::dds {

std::string_view topic_suffix(Topic topic) noexcept {
  switch (topic) {
    case Topic::kVirtualSensor:
      return "virtual_sensor";
    case Topic::kObservation:
      return "observation";
    case Topic::kEstimatorHealth:
      return "estimator_health";
    case Topic::kLeakDiagnostic:
      return "leak_diagnostic";
    case Topic::kEstimatorConsistency:
      return "estimator_consistency";
    case Topic::kUnitEstimate:
      return "unit_estimate";
  }
  return "unknown";
}

std::string topic_name(std::string_view prefix, Topic topic) {
  bool valid = !prefix.empty();
  for (const char c : prefix) {
    valid = valid && ((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
                      c == '_');
  }
  if (!valid) {
    throw std::invalid_argument("DDS topic prefix '" + std::string(prefix) +
                                "' must match [A-Za-z0-9_]+");
  }
  std::string name(prefix);
  name += '/';
  name += topic_suffix(topic);
  return name;
}

std::string_view to_string(EstimateQuality quality) noexcept {
  switch (quality) {
    case EstimateQuality::kGood:
      return "GOOD";
    case EstimateQuality::kDegraded:
      return "DEGRADED";
    case EstimateQuality::kNotReady:
      return "NOT_READY";
  }
  return "UNKNOWN";
}

std::string_view to_string(PointQuality quality) noexcept {
  switch (quality) {
    case PointQuality::kNotYetRead:
      return "NOT_YET_READ";
    case PointQuality::kGood:
      return "GOOD";
    case PointQuality::kStale:
      return "STALE";
    case PointQuality::kCommFail:
      return "COMM_FAIL";
    case PointQuality::kDeviceException:
      return "DEVICE_EXCEPTION";
    case PointQuality::kOutOfRange:
      return "OUT_OF_RANGE";
    case PointQuality::kStuck:
      return "STUCK";
  }
  return "UNKNOWN";
}

std::string_view to_string(LeakState state) noexcept {
  switch (state) {
    case LeakState::kNormal:
      return "NORMAL";
    case LeakState::kSuspect:
      return "SUSPECT";
    case LeakState::kLeak:
      return "LEAK";
  }
  return "UNKNOWN";
}

std::string_view to_string(LeakHold hold) noexcept {
  switch (hold) {
    case LeakHold::kNone:
      return "NONE";
    case LeakHold::kWarmUp:
      return "WARM_UP";
    case LeakHold::kCompressorOff:
      return "COMPRESSOR_OFF";
    case LeakHold::kStartUp:
      return "START_UP";
    case LeakHold::kCycling:
      return "CYCLING";
    case LeakHold::kDegraded:
      return "DEGRADED";
  }
  return "UNKNOWN";
}

std::string_view to_string(ConsistencyVerdict verdict) noexcept {
  switch (verdict) {
    case ConsistencyVerdict::kInsufficientData:
      return "INSUFFICIENT_DATA";
    case ConsistencyVerdict::kInBand:
      return "IN_BAND";
    case ConsistencyVerdict::kHigh:
      return "HIGH";
    case ConsistencyVerdict::kLow:
      return "LOW";
  }
  return "UNKNOWN";
}

std::string_view flag_name(std::uint32_t single_bit) noexcept {
  switch (single_bit) {
    case kFlagPredictOnly:
      return "predict_only";
    case kFlagConstraintActive:
      return "constraint_active";
    case kFlagInputHeld:
      return "input_held";
    case kFlagColdStart:
      return "cold_start";
    case kFlagNumericalReset:
      return "numerical_reset";
    case kFlagDeadlineOverrun:
      return "deadline_overrun";
    case kFlagLostTrack:
      return "lost_track";
    default:
      return "";
  }
}

}  // namespace hvac_twin::dds
