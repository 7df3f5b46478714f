// hvac-twind's command line and life: options, configuration, logger, the units started, and the
// wait for SIGTERM or SIGINT. main.cpp calls it with no hooks; the tests' hvac-twind-faults with
// its fault-injection hooks (cycle_hooks.hpp).
#pragma once

#include "daemon/runtime/cycle_hooks.hpp"

namespace hvac_twin::runtime {

// Runs the daemon; returns its exit status (see --help). `hooks` may be null (production).
int daemon_main(int argc, char** argv, CycleHooks* hooks);

}  // namespace hvac_twin::runtime
