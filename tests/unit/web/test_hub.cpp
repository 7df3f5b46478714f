// The fan-out to the event streams (io/web/hub.hpp): who gets what, bounded queues that drop and
// resync instead of blocking the publisher, and a close that wakes every waiting stream.
#include <catch2/catch.hpp>
#include <chrono>
#include <thread>

#include "io/web/hub.hpp"

using namespace hvac_twin::web;
using namespace std::chrono_literals;

namespace {
Event event(std::string text) {
  return std::make_shared<const std::string>(std::move(text));
}
}  // namespace

TEST_CASE("hub: overview streams get summaries, a unit's stream its records too", "[web][hub]") {
  Hub hub;
  auto overview = hub.subscribe("");
  auto a = hub.subscribe("unit-a");
  auto b = hub.subscribe("unit-b");
  CHECK(hub.follows("unit-a"));
  CHECK_FALSE(hub.follows("unit-c"));
  hub.publish("unit-a", false, event("record a"));
  hub.publish("unit-a", true, event("summary a"));
  hub.publish("unit-b", true, event("summary b"));
  Event got;
  const auto drain = [&](Hub::Client& c) {
    std::vector<std::string> all;
    while (hub.next(c, 0ms, got) == Hub::Next::kEvent)
      all.push_back(*got);
    return all;
  };
  CHECK(drain(*overview) == std::vector<std::string>{"summary a", "summary b"});
  CHECK(drain(*a) == std::vector<std::string>{"record a", "summary a"});
  CHECK(drain(*b) == std::vector<std::string>{"summary b"});
  CHECK(hub.next(*a, 10ms, got) == Hub::Next::kTimeout);
  CHECK(hub.stats().clients == 3);
  hub.unsubscribe(b);
  CHECK(hub.stats().clients == 2);
}

TEST_CASE("hub: at most max_clients streams", "[web][hub]") {
  Hub hub(HubLimits{2, 16, 1024});
  auto one = hub.subscribe("");
  auto two = hub.subscribe("");
  CHECK(hub.subscribe("") == nullptr);
  CHECK(hub.stats().refused_clients == 1);
  hub.unsubscribe(one);
  CHECK(hub.subscribe("") != nullptr);
}

TEST_CASE("hub: a stream that does not keep up is dropped and resynced, never waited for",
          "[web][hub]") {
  Hub hub(HubLimits{4, 100, 1 << 20});
  auto slow = hub.subscribe("");
  auto fast = hub.subscribe("");
  Event got;
  // 200 000 events while `slow` takes none: the publisher is never held up by it.
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < 200'000; ++i) {
    hub.publish("u", true, event(std::to_string(i)));
    if (i % 50 == 0)
      while (hub.next(*fast, 0ms, got) == Hub::Next::kEvent) {
      }
  }
  const auto took = std::chrono::steady_clock::now() - start;
  CHECK(took < 5s);  // about 0.1 s; the bound is for a busy sanitizer build
  // Its queue overflowed once, was dropped, and it is told to fetch the state anew; the events
  // after that are queued again, at most 100.
  CHECK(hub.stats().resyncs == 1);
  CHECK(hub.next(*slow, 0ms, got) == Hub::Next::kResync);
  hub.publish("u", true, event("after"));
  REQUIRE(hub.next(*slow, 0ms, got) == Hub::Next::kEvent);
  CHECK(*got == "after");
  // The fast stream lost nothing.
  CHECK(hub.stats().resyncs == 1);

  // The byte bound too: one event larger than the queue may hold.
  Hub small(HubLimits{1, 100, 1000});
  auto c = small.subscribe("");
  small.publish("u", true, event(std::string(600, 'x')));
  small.publish("u", true, event(std::string(600, 'y')));
  CHECK(small.next(*c, 0ms, got) == Hub::Next::kResync);
}

TEST_CASE("hub: close wakes a waiting stream and refuses new ones", "[web][hub]") {
  Hub hub;
  auto c = hub.subscribe("");
  Hub::Next result = Hub::Next::kTimeout;
  std::thread waiter([&] {
    Event got;
    result = hub.next(*c, 30s, got);
  });
  std::this_thread::sleep_for(50ms);
  const auto start = std::chrono::steady_clock::now();
  hub.close();
  waiter.join();
  CHECK(std::chrono::steady_clock::now() - start < 5s);
  CHECK(result == Hub::Next::kClosed);
  CHECK(hub.subscribe("") == nullptr);
}
