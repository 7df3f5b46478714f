// UnitPipeline, filter consistency: every cycle's measurement reports go to the consistency
// monitor (daemon/estimation/consistency_monitor.hpp), whose window figures are published on
// "<prefix>/estimator_consistency", one sample per measured point and one for all of them
// (point dds::kAllPoints, "*"), every cycle: the state QoS's deadline counts per instance.
//
// The log says when a figure's verdict turns HIGH (the filter's sigmas are too small for what
// it sees) and when that episode ends, once each, not every cycle. The episode ends when the
// mean is LOW, or back in the band at most half-way between 1 and the band's top, or has been
// in the band (or low) for a whole window: a mean that hovers at the band's edge does not flood
// the journal (the published verdict has no such hysteresis). Too few samples (a point's
// outage) neither start nor end an episode.
#include <algorithm>
#include <cmath>
#include <string_view>

#include "daemon/runtime/unit_pipeline.hpp"

namespace hvac_twin::runtime {
namespace {

dds::ConsistencyVerdict wire_verdict(est::ConsistencyVerdict v) {
  switch (v) {
    case est::ConsistencyVerdict::kInsufficientData:
      return dds::ConsistencyVerdict::kInsufficientData;
    case est::ConsistencyVerdict::kInBand:
      return dds::ConsistencyVerdict::kInBand;
    case est::ConsistencyVerdict::kHigh:
      return dds::ConsistencyVerdict::kHigh;
    case est::ConsistencyVerdict::kLow:
      return dds::ConsistencyVerdict::kLow;
  }
  return dds::ConsistencyVerdict::kInsufficientData;
}

}  // namespace

// The window: round(consistency_window_s / period_s) cycles, and at least as many as a verdict
// needs samples (the configuration bounds the ratio above).
void UnitPipeline::bind_consistency() {
  est::ConsistencyOptions o;
  o.window_cycles = std::max<std::size_t>(
      o.min_samples,
      static_cast<std::size_t>(std::llround(unit_.estimator.consistency_window_s / period_s_)));
  consistency_ = std::make_unique<est::ConsistencyMonitor>(measured_.size(), o);
  consistency_episodes_.assign(measured_.size() + 1, ConsistencyEpisode{});
  const auto& e = unit_.estimator;
  if (e.adaptive_noise_min < 1.0 || e.adaptive_noise_max > 1.0) {
    noise_ = std::make_unique<est::NoiseAdapter>(
        measured_.size(), est::NoiseAdapterOptions{.window_cycles = o.window_cycles,
                                                   .min_samples = o.min_samples,
                                                   .min_factor = e.adaptive_noise_min,
                                                   .max_factor = e.adaptive_noise_max,
                                                   .clip = e.nis_gate,
                                                   .hold_updates = est::kLostAfterUpdates});
    for (const auto& b : measured_)
      told_variance_.push_back(b.variance);
    told_reports_.resize(measured_.size());
    log_->info(
        "unit {}: adaptive measurement noise: each point's variance x [{}, {}], learnt over {} "
        "cycles",
        unit_.id, e.adaptive_noise_min, e.adaptive_noise_max, o.window_cycles);
  }
}

void UnitPipeline::step_consistency() {
  if (noise_) {
    // Judged against the told noise: a point whose noise had to be inflated still shows HIGH.
    for (std::size_t i = 0; i < reports_.size(); ++i) {
      told_reports_[i] = reports_[i];
      told_reports_[i].test_ratio =
          est::NoiseAdapter::told_test_ratio(reports_[i], z_[i].variance, told_variance_[i]);
    }
    consistency_->add(told_reports_);
  } else {
    consistency_->add(reports_);
  }
  for (std::size_t f = 0; f <= measured_.size(); ++f)
    note_consistency(f);
}

void UnitPipeline::note_consistency(std::size_t figure) {
  const bool all = figure == measured_.size();
  const est::ConsistencyFigure& f = all ? consistency_->overall() : consistency_->point(figure);
  ConsistencyEpisode& e = consistency_episodes_[figure];
  using V = est::ConsistencyVerdict;
  if (f.verdict == V::kHigh) e.calm_cycles = 0;
  if (f.verdict == V::kInBand || f.verdict == V::kLow) ++e.calm_cycles;
  const bool starts = !e.high && f.verdict == V::kHigh;
  const bool ends =
      e.high && (f.verdict == V::kLow ||
                 (f.verdict == V::kInBand && (f.mean_nis <= 0.5 * (1.0 + f.band_high) ||
                                              e.calm_cycles >= consistency_->window_cycles())));
  if (!starts && !ends) return;  // nothing to say: no formatting, no allocation
  e.high = starts;
  const std::string_view kind = all ? "all measured points" : "point ";
  const std::string_view name =
      all ? std::string_view() : unit_.points[measured_[figure].point].name;
  if (starts)
    log_->warn(
        "unit {}: {}{}: innovations larger than the filter expects: mean NIS {:.2f} over the last "
        "{} samples, above the 95 % band [{:.2f}, {:.2f}]; {:.0f} % rejected by the gate (sigmas "
        "too small: model error, a sensor fault or measurement noise set too low)",
        unit_.id, kind, name, f.mean_nis, f.samples, f.band_low, f.band_high,
        100.0 * f.rejected_share);
  else
    log_->info("unit {}: {}{}: innovations consistent again: mean NIS {:.2f} over {} samples ({})",
               unit_.id, kind, name, f.mean_nis, f.samples, est::to_string(f.verdict));
}

void UnitPipeline::publish_consistency(std::int64_t stamp_ns, std::uint64_t cycle) {
  const auto window = static_cast<std::uint32_t>(consistency_->window_cycles());
  for (std::size_t i = 0; i <= measured_.size(); ++i) {
    const bool all = i == measured_.size();
    const est::ConsistencyFigure& f = all ? consistency_->overall() : consistency_->point(i);
    publisher_->publish(dds::ConsistencySample{
        .point = all ? dds::kAllPoints : std::string_view(unit_.points[measured_[i].point].name),
        .window_cycles = window,
        .samples = static_cast<std::uint32_t>(f.samples),
        .mean_nis = f.mean_nis,
        .band_low = f.band_low,
        .band_high = f.band_high,
        .verdict = wire_verdict(f.verdict),
        .rejected_share = f.rejected_share,
        .timestamp_ns = stamp_ns,
        .cycle = cycle});
  }
}

}  // namespace hvac_twin::runtime
