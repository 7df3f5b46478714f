// A PointSource that hands the pipeline the recorded snapshot of the cycle being replayed.
#pragma once

#include <algorithm>

#include "daemon/recording/recording_format.hpp"
#include "io/modbus/point_source.hpp"

namespace hvac_twin::replay {

class RecordingSource final : public modbus::PointSource {
 public:
  void start() override {}
  void stop() override {}
  // The cycle the next snapshot() returns; must outlive that call.
  void set(const recording::RecordedCycle& cycle) { cycle_ = &cycle; }

  std::size_t snapshot(std::span<modbus::PointSample> out, std::int64_t /*now*/,
                       modbus::DeviceStatus* status) const noexcept override {
    if (cycle_ == nullptr) return 0;
    const std::size_t n = std::min(out.size(), cycle_->samples.size());
    std::copy_n(cycle_->samples.begin(), n, out.begin());
    if (status != nullptr) {
      *status = modbus::DeviceStatus{};
      status->running = true;
      status->connected = cycle_->connected;
    }
    return n;
  }

 private:
  const recording::RecordedCycle* cycle_ = nullptr;
};

}  // namespace hvac_twin::replay
