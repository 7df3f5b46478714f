#include "daemon/replay/csv_sink.hpp"

#include <cinttypes>
#include <cmath>
#include <limits>

namespace hvac_twin::replay {
namespace {

constexpr double kEmpty = std::numeric_limits<double>::quiet_NaN();
constexpr std::size_t kPerOutput = 2;  // value, sigma
constexpr std::size_t kPerPoint = 4;   // predicted, innovation, test_ratio, fused
// The leak_diagnostic sample's (a prefix of their own: the model has outputs "charge" and
// "leak_rate" too, and the diagnostic's leak rate is clamped at 0).
constexpr const char* kLeakColumns[] = {"leak_diag_charge",           "leak_diag_charge_sigma",
                                        "leak_diag_leak_rate",        "leak_diag_leak_rate_sigma",
                                        "leak_diag_rate_cusum",       "leak_diag_charge_cusum",
                                        "leak_diag_charge_reference", "leak_diag_threshold"};
constexpr std::size_t kPerLeak = std::size(kLeakColumns);

}  // namespace

CsvSink::CsvSink(std::FILE* out, std::vector<std::string> outputs, std::vector<std::string> points,
                 bool leak)
    : out_(out), outputs_(std::move(outputs)), points_(std::move(points)), leak_(leak) {
  for (std::size_t i = 0; i < outputs_.size(); ++i)
    output_index_.emplace(outputs_[i], i);
  for (std::size_t i = 0; i < points_.size(); ++i)
    point_index_.emplace(points_[i], i);
  values_.assign(kPerOutput * outputs_.size() + kPerPoint * points_.size() + (leak_ ? kPerLeak : 0),
                 kEmpty);
  quality_.reserve(16);
  leak_state_.reserve(16);
}

void CsvSink::write_header() {
  std::fputs("cycle,timestamp_ns,quality,flags,fused_points", out_);
  for (const auto& o : outputs_)
    std::fprintf(out_, ",%s,%s_sigma", o.c_str(), o.c_str());
  for (const auto& p : points_)
    std::fprintf(out_, ",%s_predicted,%s_innovation,%s_test_ratio,%s_fused", p.c_str(), p.c_str(),
                 p.c_str(), p.c_str());
  if (leak_) {
    for (const char* c : kLeakColumns)
      std::fprintf(out_, ",%s", c);
    std::fputs(",leak_diag_state", out_);
  }
  std::fputc('\n', out_);
}

dds::PublishStatus CsvSink::publish(const dds::VirtualSensorSample& s) noexcept {
  const auto it = output_index_.find(s.name);
  if (it == output_index_.end()) return dds::PublishStatus::kInvalidName;
  values_[kPerOutput * it->second] = s.value;
  values_[kPerOutput * it->second + 1] = s.sigma;
  ++stats_.published;
  return dds::PublishStatus::kOk;
}

// The cycle's flags and fused points (the same on every virtual_sensor sample of the cycle).
dds::PublishStatus CsvSink::publish(const dds::UnitEstimateSample& s) noexcept {
  flags_ = s.flags;
  fused_points_ = s.fused_points;
  have_estimate_ = true;
  ++stats_.published;
  return dds::PublishStatus::kOk;
}

dds::PublishStatus CsvSink::publish(const dds::ObservationSample& s) noexcept {
  const auto it = point_index_.find(s.point);
  if (it == point_index_.end()) return dds::PublishStatus::kInvalidName;
  const std::size_t at = kPerOutput * outputs_.size() + kPerPoint * it->second;
  const bool tested = s.innovation_variance > 0.0;
  values_[at] = tested ? s.predicted : kEmpty;
  values_[at + 1] = tested ? s.innovation : kEmpty;
  values_[at + 2] = tested ? s.test_ratio : kEmpty;
  values_[at + 3] = s.fused ? 1.0 : 0.0;
  ++stats_.published;
  return dds::PublishStatus::kOk;
}

dds::PublishStatus CsvSink::publish(const dds::LeakDiagnosticSample& s) noexcept {
  if (!leak_) return dds::PublishStatus::kDdsError;
  const std::size_t at = kPerOutput * outputs_.size() + kPerPoint * points_.size();
  const double v[kPerLeak] = {s.charge,     s.charge_sigma, s.leak_rate,        s.leak_rate_sigma,
                              s.rate_cusum, s.charge_cusum, s.charge_reference, s.threshold};
  for (std::size_t i = 0; i < kPerLeak; ++i)
    values_[at + i] = v[i];
  leak_state_ = dds::to_string(s.state);
  ++stats_.published;
  return dds::PublishStatus::kOk;
}

dds::PublishStatus CsvSink::publish(const dds::HealthSample& s) noexcept {
  quality_ = dds::to_string(s.quality);
  std::fprintf(out_, "%" PRIu64 ",%" PRId64 ",%s,", s.cycle, s.timestamp_ns, quality_.c_str());
  if (have_estimate_)
    std::fprintf(out_, "%" PRIu32 ",%" PRIu64, flags_, fused_points_);
  else
    std::fputc(',', out_);
  for (const double v : values_) {
    if (std::isnan(v))
      std::fputc(',', out_);
    else
      std::fprintf(out_, ",%.17g", v);
  }
  if (leak_) std::fprintf(out_, ",%s", leak_state_.c_str());
  std::fputc('\n', out_);
  ++rows_;
  ++stats_.published;
  clear_row();
  return dds::PublishStatus::kOk;
}

void CsvSink::clear_row() {
  std::fill(values_.begin(), values_.end(), kEmpty);
  leak_state_.clear();
  have_estimate_ = false;
  flags_ = 0;
  fused_points_ = 0;
}

}  // namespace hvac_twin::replay
