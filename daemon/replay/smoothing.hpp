// Fixed-interval smoothing in a replay (hvac-twin-replay --smooth): the Rauch-Tung-Striebel
// smoother (est::RtsSmoother) over what the EKF computed forwards, for after-the-fact estimates
// of every model output (the charge, the heat flows) with their sigma, from all measurements of
// the interval, later ones included.
//
// Forwards, per cycle, it keeps the filter's prior after the prediction (x⁻, P⁻, F) and its
// posterior after the update (x, P) with the cycle's inputs, spilled to a temporary file (a day
// of the heat pump is gigabytes of covariances; memory holds only the smoothed outputs). The
// chain breaks where the filter did not carry its estimate from one cycle to the next: a failed
// prediction, a restart or covariance reset (flag numerical_reset), estimates not ready. Each
// piece is smoothed on its own, ending at the filter's last estimate of the piece.
#pragma once

#include <atomic>
#include <cstdint>
#include <cstdio>
#include <string_view>
#include <vector>

#include "daemon/estimation/ekf.hpp"
#include "daemon/runtime/cycle_hooks.hpp"
#include "daemon/runtime/unit_pipeline.hpp"

namespace hvac_twin::replay {

class Smoothing final : public runtime::CycleHooks {
 public:
  // n states, m outputs, k inputs of the model. Throws std::runtime_error if no temporary file
  // can be made.
  Smoothing(std::size_t n, std::size_t m, std::size_t k);
  ~Smoothing() override;
  Smoothing(const Smoothing&) = delete;
  Smoothing& operator=(const Smoothing&) = delete;

  // The pipeline whose filter (an EKF) the next cycles run; a new one breaks the chain.
  void attach(const runtime::UnitPipeline* pipeline);
  void after_predict(std::string_view unit, std::uint64_t cycle,
                     const std::atomic<bool>& stopping) override;
  bool poison_output(std::uint64_t /*cycle*/) override { return false; }
  // After the cycle's run_cycle().
  void end_cycle(std::uint64_t cycle, std::int64_t timestamp_ns,
                 const runtime::CycleOutcome& outcome);

  // The backward pass; writes one CSV row per cycle: cycle, timestamp_ns, then every output's
  // smoothed value and sigma (empty where the filter had no estimate). Returns the number of
  // chain breaks (pieces - 1).
  std::uint64_t write(std::FILE* out, const plant::ContinuousModel& model);

 private:
  void spill(const double* data, std::size_t count);
  void load(std::uint64_t index);  // record `index` into rec_

  std::size_t n_, m_, k_;
  std::size_t record_doubles_;
  std::FILE* file_ = nullptr;
  const runtime::UnitPipeline* pipeline_ = nullptr;
  const est::Ekf* ekf_ = nullptr;              // pipeline_'s filter
  std::uint64_t predicts_ = 0, failures_ = 0;  // the filter's counters at the last cycle's end
  bool predicted_ = false;                     // this cycle predicted successfully
  bool last_valid_ = false;                    // the last cycle had estimates
  std::vector<double> rec_;                    // one record: header, x⁻, P⁻, F, x, P, u
  std::uint64_t records_ = 0;
};

}  // namespace hvac_twin::replay
