// The state hvac-twin-web serves: the Store behind one mutex, and the Hub that pushes its changes
// to the browsers. The DDS side calls ingest()/tick(); the HTTP side the JSON readers and hub().
//
// Threads: every member is safe to call from any thread. The store's mutex is held while a
// batch is stored and while a reader encodes (history: only while it copies its windows, not
// while it formats them); events are handed to the Hub after the mutex is released. No call
// here waits on a socket. Allocation: every call allocates (JSON, events).
#pragma once

#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "io/dds/subscriber.hpp"
#include "io/web/hub.hpp"
#include "io/web/json.hpp"
#include "io/web/store.hpp"

namespace hvac_twin::web {

class Dashboard {
 public:
  Dashboard(StoreLimits store_limits, HubLimits hub_limits);

  // One batch from the Subscriber, arrived at `now` (CLOCK_MONOTONIC ns): stored, then the
  // records pushed to the streams that follow their unit and changed summaries to all.
  void ingest(const std::vector<dds::Record>& records, const std::vector<dds::InstanceLost>& lost,
              std::int64_t now);
  // No writer on the topics is alive any more: every unit turns stale.
  void publishers_lost(std::int64_t now);
  // Re-evaluates the deadlines at `now` and pushes the summaries that changed. Returns the
  // earliest time a unit may turn stale next (INT64_MAX: none).
  std::int64_t tick(std::int64_t now);

  std::string overview(std::int64_t now) const;
  // nullopt: no such unit.
  std::optional<std::string> unit(std::string_view site, std::string_view unit,
                                  std::int64_t now) const;
  std::optional<std::string> history(std::string_view site, std::string_view unit,
                                     const HistoryRequest& request) const;
  std::size_t units() const;

  Hub& hub() { return hub_; }

 private:
  void publish_summaries(const std::vector<int>& changed, std::int64_t now);

  mutable std::mutex mutex_;  // guards store_
  Store store_;
  Hub hub_;
};

}  // namespace hvac_twin::web
