#include "io/web/feed.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <vector>

namespace hvac_twin::web {
namespace {

std::int64_t monotonic_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// Whether any writer of the health topic (every unit publishes it each cycle) is alive.
bool any_publisher_alive(const dds::Subscriber& subscriber) {
  return subscriber.status(dds::Topic::kEstimatorHealth).alive_writers > 0;
}

}  // namespace

int follow(dds::Subscriber& subscriber, Dashboard& dashboard, const std::atomic<bool>& stop) {
  constexpr std::int64_t kMaxWaitNs = 100'000'000;  // a stop is seen within 100 ms
  std::vector<dds::Record> records;
  std::vector<dds::InstanceLost> lost;
  bool publishers_alive = false;
  while (!stop.load(std::memory_order_relaxed)) {
    const std::int64_t next_deadline = dashboard.tick(monotonic_ns());
    const std::int64_t wait =
        std::clamp<std::int64_t>(next_deadline - monotonic_ns(), 1'000'000, kMaxWaitNs);
    records.clear();
    lost.clear();
    if (subscriber.wait_and_take(std::chrono::nanoseconds(wait), records, &lost) < 0) {
      std::fprintf(stderr, "hvac-twin-web: DDS error %d while reading\n", subscriber.last_error());
      return 1;
    }
    if (!records.empty() || !lost.empty()) dashboard.ingest(records, lost, monotonic_ns());
    // Every writer gone at once (one daemon serving the site, killed): all units are stale,
    // whether or not Cyclone delivered a per-instance notice.
    const bool alive = any_publisher_alive(subscriber);
    if (publishers_alive && !alive) dashboard.publishers_lost(monotonic_ns());
    publishers_alive = alive;
  }
  return 0;
}

}  // namespace hvac_twin::web
