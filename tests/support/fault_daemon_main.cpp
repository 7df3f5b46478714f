// hvac-twind-faults: hvac-twind with fault-injection hooks in every unit's cycle, for the
// integration tests of a hung cycle, overrunning cycles and a NaN estimate. Built with the tests,
// never installed. Its own options, taken out before the rest goes to the daemon's command line:
//
//   --fault-hang-at-cycle N        cycle N of every unit blocks until shut-down
//   --fault-cycle-delay-ms MS      every cycle sleeps MS ms after predict
//   --fault-nan-output-at-cycle N  cycle N hands the publisher a NaN estimate
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string_view>
#include <thread>
#include <vector>

#include "daemon/runtime/daemon_main.hpp"

namespace {

class FaultHooks final : public hvac_twin::runtime::CycleHooks {
 public:
  std::uint64_t hang_at_cycle = 0;        // 0: never
  std::int64_t extra_cycle_delay_ns = 0;  // forces overruns
  std::uint64_t nan_output_at_cycle = 0;  // 0: never

  void after_predict(std::string_view unit, std::uint64_t cycle,
                     const std::atomic<bool>& stopping) override {
    if (hang_at_cycle != 0 && cycle == hang_at_cycle) {
      std::fprintf(stderr, "hvac-twind-faults: unit %.*s: fault hook: cycle %llu hangs\n",
                   static_cast<int>(unit.size()), unit.data(),
                   static_cast<unsigned long long>(cycle));
      while (!stopping.load())
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    if (extra_cycle_delay_ns > 0)
      std::this_thread::sleep_for(std::chrono::nanoseconds(extra_cycle_delay_ns));
  }
  bool poison_output(std::uint64_t cycle) override {
    return nan_output_at_cycle != 0 && cycle == nan_output_at_cycle;
  }
};

bool parse_number(const char* text, double& out) {
  char* end = nullptr;
  out = std::strtod(text, &end);
  return end != text && *end == '\0';
}

}  // namespace

int main(int argc, char** argv) {
  FaultHooks hooks;
  std::vector<char*> rest{argv[0]};
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg.rfind("--fault-", 0) != 0) {
      rest.push_back(argv[i]);
      continue;
    }
    double number = 0.0;
    if (i + 1 >= argc || !parse_number(argv[++i], number) || number < 0.0) {
      std::fprintf(stderr, "hvac-twind-faults: %s needs a number\n", argv[i - 1]);
      return 2;
    }
    if (arg == "--fault-hang-at-cycle") {
      hooks.hang_at_cycle = static_cast<std::uint64_t>(number);
    } else if (arg == "--fault-cycle-delay-ms") {
      hooks.extra_cycle_delay_ns = static_cast<std::int64_t>(number * 1e6);
    } else if (arg == "--fault-nan-output-at-cycle") {
      hooks.nan_output_at_cycle = static_cast<std::uint64_t>(number);
    } else {
      std::fprintf(stderr, "hvac-twind-faults: unknown option %s\n", argv[i - 1]);
      return 2;
    }
  }
  rest.push_back(nullptr);
  return hvac_twin::runtime::daemon_main(static_cast<int>(rest.size()) - 1, rest.data(), &hooks);
}
