// UnitPipeline, leak detection: binds the detector to the model's leak-rate and charge outputs
// and its compressor-speed input, steps it once per cycle and publishes the diagnosis.
#include <spdlog/fmt/fmt.h>

#include <algorithm>
#include <string>

#include "daemon/runtime/leak_options.hpp"
#include "daemon/runtime/unit_pipeline.hpp"

namespace hvac_twin::runtime {
namespace {

dds::LeakState wire_state(est::LeakState s) {
  switch (s) {
    case est::LeakState::kNormal:
      return dds::LeakState::kNormal;
    case est::LeakState::kSuspect:
      return dds::LeakState::kSuspect;
    case est::LeakState::kLeak:
      return dds::LeakState::kLeak;
  }
  return dds::LeakState::kNormal;
}

dds::LeakHold wire_hold(est::HoldReason h) {
  switch (h) {
    case est::HoldReason::kNone:
      return dds::LeakHold::kNone;
    case est::HoldReason::kWarmUp:
      return dds::LeakHold::kWarmUp;
    case est::HoldReason::kCompressorOff:
      return dds::LeakHold::kCompressorOff;
    case est::HoldReason::kStartUp:
      return dds::LeakHold::kStartUp;
    case est::HoldReason::kCycling:
      return dds::LeakHold::kCycling;
    case est::HoldReason::kDegraded:
      return dds::LeakHold::kDegraded;
  }
  return dds::LeakHold::kWarmUp;
}

}  // namespace

// Leak detection needs a leak rate the filter estimates (an augmented state, not a fixed
// parameter), the charge it is judged against, and the compressor speed for the holds.
void UnitPipeline::bind_leak_detection(const config::LeakDetectionConfig& c) {
  const plant::ModelLayout& layout = model_->layout();
  const auto leak_state = layout.state("leak_rate");
  const auto charge_state = layout.state("charge");
  const auto leak_out = layout.output("leak_rate");
  const auto charge_out = layout.output("charge");
  std::optional<std::size_t> speed;
  for (std::size_t i = 0; i < layout.inputs.size(); ++i)
    if (layout.inputs[i].name == "compressor_speed") speed = i;
  if (!leak_state || !layout.states[*leak_state].augmented || !charge_state || !leak_out ||
      !charge_out || !speed)
    return;
  leak_output_ = *leak_out;
  charge_output_ = *charge_out;
  speed_input_ = *speed;
  nameplate_charge_ = layout.states[*charge_state].initial;
  false_alarm_days_ = c.false_alarm_interval_days;
  leak_ = std::make_unique<est::LeakDetector>(leak_detector_options(c, nameplate_charge_));
}

void UnitPipeline::step_leak_detector(bool degraded, bool estimates_valid) {
  if (!estimates_valid) return;  // nothing to judge; the last report stands
  const est::LeakReport& r =
      // The leak rate with its published sigma (the model's structural wander included: nothing
      // cancels it), the charge with the filter's own: the detector compares the charge with its
      // own reference, where the model's structural offset cancels.
      leak_->step(model_time_s_, y_[leak_output_], sigma_[leak_output_], y_[charge_output_],
                  filter_sigma_[charge_output_], u_[speed_input_], degraded);
  if (r.reference_learned && !references_logged_) {
    // The unit as commissioned: what every later deficit is measured from.
    log_->info("unit {}: leak detector learnt its reference charges: {}", unit_.id,
               describe_leak_detector());
    references_logged_ = true;
  }
  if (r.state == last_leak_state_) return;
  const auto level = r.state == est::LeakState::kNormal ? spdlog::level::info : spdlog::level::warn;
  log_->log(level,
            "unit {}: refrigerant leak state {} -> {} (CUSUM leak rate {:.2f}, charge deficit "
            "{:.2f}, threshold {:.2f})",
            unit_.id, est::to_string(last_leak_state_), est::to_string(r.state), r.rate_cusum,
            r.charge_cusum, r.threshold);
  last_leak_state_ = r.state;
}

std::string UnitPipeline::describe_leak_detector() const {
  const est::LeakReport& r = leak_->report();
  std::string s = fmt::format("state {}, {} decisions, reference charges ", est::to_string(r.state),
                              r.decisions);
  if (!r.reference_learned) return s + "not learnt yet";
  // Per compressor-speed band the reference period ran in (the detector's bands).
  const double width = std::max(leak_->options().reference_band_hz, 1.0);
  bool any = false;
  for (std::size_t b = 0; b < est::LeakDetector::kBands; ++b) {
    const double lo = static_cast<double>(b) * width;
    const double reference = leak_->reference_charge(lo + 0.5 * width);
    if (reference < 0.0) continue;
    s += fmt::format("{}{:.0f}-{} Hz {:.4f} kg", any ? ", " : "", lo,
                     b + 1 < est::LeakDetector::kBands ? fmt::format("{:.0f}", lo + width) : "",
                     reference);
    any = true;
  }
  return s + " (other speeds judged on the leak rate alone)";
}

void UnitPipeline::publish_leak(std::int64_t stamp_ns, std::uint64_t cycle,
                                dds::EstimateQuality quality, bool estimates_valid) {
  const est::LeakReport& r = leak_->report();
  // The episode's wall-clock start, kept until the state is NORMAL again.
  if (r.state == est::LeakState::kNormal) {
    suspect_since_ns_ = leak_since_ns_ = 0;
  } else {
    if (suspect_since_ns_ == 0) suspect_since_ns_ = stamp_ns;
    if (r.state == est::LeakState::kLeak && leak_since_ns_ == 0) leak_since_ns_ = stamp_ns;
  }
  const double reference = std::max(0.0, leak_->reference_charge(u_[speed_input_]));  // -1: none
  publisher_->publish(dds::LeakDiagnosticSample{
      .state = wire_state(r.state),
      .hold = estimates_valid ? wire_hold(r.hold) : dds::LeakHold::kWarmUp,
      .charge = estimates_valid ? y_[charge_output_] : 0.0,
      .charge_sigma = estimates_valid ? sigma_[charge_output_] : 0.0,
      .nameplate_charge = nameplate_charge_,
      // The filter's leak rate is signed (its wander goes both ways; the leak_rate virtual
      // sensor shows it); the diagnosis reports the loss it implies, >= 0.
      .leak_rate = estimates_valid ? std::max(0.0, y_[leak_output_]) : 0.0,
      .leak_rate_sigma = estimates_valid ? sigma_[leak_output_] : 0.0,
      .cusum = r.cusum,
      .rate_cusum = r.rate_cusum,
      .charge_cusum = r.charge_cusum,
      .charge_reference = estimates_valid ? reference : 0.0,
      .threshold = leak_->threshold(),
      .false_alarm_interval_days = false_alarm_days_,
      .decisions = r.decisions,
      .suspect_since_ns = suspect_since_ns_,
      .leak_since_ns = leak_since_ns_,
      .quality = estimates_valid ? quality : dds::EstimateQuality::kNotReady,
      .timestamp_ns = stamp_ns,
      .cycle = cycle});
}

}  // namespace hvac_twin::runtime
