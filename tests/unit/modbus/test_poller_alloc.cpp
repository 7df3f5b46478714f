// The periodic path does not allocate: neither the poller thread (polls, decoding, a transport
// error, closing and reconnecting) nor snapshot() on the caller's thread. This executable
// replaces the global operator new with a counting one, so it is kept apart from other tests.
#include <atomic>
#include <catch2/catch.hpp>
#include <cstdlib>
#include <new>
#include <thread>
#include <vector>

#include "io/modbus/poller.hpp"
#include "tests/support/modbus_test_server.hpp"
#include "tests/unit/modbus/modbus_test_util.hpp"

namespace {
std::atomic<std::thread::id> g_watched_thread{};
std::atomic<long> g_watched_allocations{0};
thread_local long t_allocations = 0;

void count_allocation() noexcept {
  ++t_allocations;
  if (std::this_thread::get_id() == g_watched_thread.load()) g_watched_allocations.fetch_add(1);
}
}  // namespace

void* operator new(std::size_t size) {
  count_allocation();
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
  return operator new(size);
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  count_allocation();
  return std::malloc(size == 0 ? 1 : size);
}
void* operator new[](std::size_t size, const std::nothrow_t& tag) noexcept {
  return operator new(size, tag);
}
void operator delete(void* p, const std::nothrow_t&) noexcept {
  std::free(p);
}
void operator delete[](void* p, const std::nothrow_t&) noexcept {
  std::free(p);
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete[](void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  std::free(p);
}

using namespace hvac_twin::modbus;
using hvac_twin::config::ValueType;
using hvac_twin::test_support::ModbusTestServer;

TEST_CASE("poller: no allocation in the poll loop, the error path or snapshot()") {
  ModbusTestServer server;
  server.start();
  std::vector<hvac_twin::config::PointConfig> points = {test::holding("a", 0, ValueType::kFloat32),
                                                        test::holding("b", 2),
                                                        test::input("c", 0, ValueType::kInt32)};
  points[1].range_min = 0;
  points[1].range_max = 10;
  server.set_value(points[0], 1.5);
  server.set_value(points[1], 50);  // OUT_OF_RANGE: the event path runs too
  Poller poller(test::fast_device(server.port()), points, [](const Event&) {
    g_watched_thread.store(std::this_thread::get_id());  // the poller thread
  });
  poller.start();

  std::vector<PointSample> out(points.size());
  DeviceStatus status;
  auto polls_ok = [&] {
    poller.snapshot(out, monotonic_ns(), &status);
    return status.polls_ok;
  };
  REQUIRE(test::eventually([&] { return polls_ok() >= 2; }));
  REQUIRE(g_watched_thread.load() != std::thread::id{});

  g_watched_allocations.store(0);
  // A fault inside the measured window: transport error, COMM_FAIL, back-off, reconnect.
  server.disconnect_clients();
  REQUIRE(test::eventually([&] {
    poller.snapshot(out, monotonic_ns(), &status);
    return status.reconnects == 1 && out[0].quality == PointQuality::kGood;
  }));
  const std::uint64_t target = polls_ok() + 3;
  REQUIRE(test::eventually([&] { return polls_ok() >= target; }));
  CHECK(g_watched_allocations.load() == 0);
  CHECK(status.transport_errors == 1);

  const long before = t_allocations;
  for (int i = 0; i < 1000; ++i)
    poller.snapshot(out, monotonic_ns(), &status);
  CHECK(t_allocations == before);
  poller.stop();
}
