// Running the daemon under strace to inject system-call faults (fsync errors, stalls).
#pragma once

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>

#include "process.hpp"

namespace hvac_twin::test {

// The first child of `pid` (the daemon under strace), or 0.
inline pid_t first_child(pid_t pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/task/" + std::to_string(pid) + "/children");
  pid_t child = 0;
  f >> child;
  return child;
}

// strace is installed and may trace here (not in every container).
inline bool strace_works() {
  using namespace std::chrono_literals;
  if (!std::filesystem::exists("/usr/bin/strace")) return false;
  Process probe("/usr/bin/strace", {"-qq", "-o", "/dev/null", "/bin/true"}, "/dev/null",
                "/dev/null");
  return probe.wait(10s) == 0;
}

}  // namespace hvac_twin::test
