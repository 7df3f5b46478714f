// Hooks into every unit's cycle, for fault-injection tests only. The daemon runs with none (a null
// pointer: one branch per cycle); the tests' build of the daemon, hvac-twind-faults
// (tests/support/fault_daemon_main.cpp), implements them behind its --fault-* options.
#pragma once

#include <atomic>
#include <cstdint>
#include <string_view>

namespace hvac_twin::runtime {

class CycleHooks {
 public:
  virtual ~CycleHooks() = default;
  // After the prediction of `cycle` of `unit`, before its deadline is checked: may sleep, or block
  // until `stopping` (a hung cycle).
  virtual void after_predict(std::string_view unit, std::uint64_t cycle,
                             const std::atomic<bool>& stopping) = 0;
  // Whether the first estimate of `cycle` is handed to the publisher as NaN (its guard must drop
  // it).
  virtual bool poison_output(std::uint64_t cycle) = 0;
};

}  // namespace hvac_twin::runtime
