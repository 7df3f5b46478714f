// The DDS side of hvac-twin-web: takes every sample the Subscriber delivers and hands it to the
// Dashboard, and re-checks the units' deadlines in between, until told to stop.
//
// Threads: runs on the caller's thread (main), the only one that touches the Subscriber. It waits
// only on DDS (at most 100 ms, or until the next unit deadline) and on the Dashboard's store
// mutex, never on a browser. Allocation: per batch (records, events); not a real-time path.
#pragma once

#include <atomic>

#include "io/dds/subscriber.hpp"
#include "io/web/dashboard.hpp"

namespace hvac_twin::web {

// Returns 0 once `stop` is set, 1 on a DDS error (reported on stderr).
int follow(dds::Subscriber& subscriber, Dashboard& dashboard, const std::atomic<bool>& stop);

}  // namespace hvac_twin::web
