// A UnitSink that writes one CSV row per cycle: what the daemon would have published (the
// virtual sensors with their sigma, the quality and flags, every measured point's prediction,
// innovation, test ratio and fusion, and the leak diagnostic). Doubles are printed with 17
// significant digits, so a row carries the published values exactly; a value not published in
// a cycle (estimates not ready, no leak detector) is an empty field.
#pragma once

#include <cstdio>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "io/dds/unit_sink.hpp"

namespace hvac_twin::replay {

class CsvSink final : public dds::UnitSink {
 public:
  // outputs: the model's output names; points: the unit's measured point names (in the order
  // the pipeline publishes them); leak: the unit has a leak detector. `out` stays open.
  CsvSink(std::FILE* out, std::vector<std::string> outputs, std::vector<std::string> points,
          bool leak);

  // The header row (the column names).
  void write_header();

  dds::PublishStatus publish(const dds::VirtualSensorSample& s) noexcept override;
  dds::PublishStatus publish(const dds::ObservationSample& s) noexcept override;
  dds::PublishStatus publish(const dds::HealthSample& s) noexcept override;  // ends the row
  dds::PublishStatus publish(const dds::LeakDiagnosticSample& s) noexcept override;
  dds::PublishStatus publish(const dds::ConsistencySample&) noexcept override {
    return dds::PublishStatus::kOk;
  }
  dds::PublishStatus publish(const dds::UnitEstimateSample& s) noexcept override;
  dds::PublishStatus assert_liveliness() noexcept override { return dds::PublishStatus::kOk; }
  [[nodiscard]] dds::PublisherStats stats() const noexcept override { return stats_; }

  [[nodiscard]] std::uint64_t rows() const { return rows_; }

 private:
  void clear_row();

  std::FILE* out_;
  std::vector<std::string> outputs_, points_;
  bool leak_;
  std::map<std::string, std::size_t, std::less<>> output_index_, point_index_;
  std::vector<double> values_;  // this cycle's numeric columns, NaN: empty
  std::string quality_, leak_state_;
  std::uint32_t flags_ = 0;
  std::uint64_t fused_points_ = 0;
  bool have_estimate_ = false;
  dds::PublisherStats stats_;
  std::uint64_t rows_ = 0;
};

}  // namespace hvac_twin::replay
