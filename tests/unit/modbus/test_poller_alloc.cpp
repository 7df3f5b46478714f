// The periodic path does not allocate: neither the poller thread (polls, decoding, a transport
// error, closing and reconnecting) nor snapshot() on the caller's thread. This executable
// replaces the global operator new with a counting one (tests/support/alloc_counter.hpp), so it
// is kept apart from other tests.
#include <atomic>
#include <catch2/catch.hpp>
#include <thread>
#include <vector>

#include "io/modbus/poller.hpp"
#include "tests/support/alloc_counter.hpp"
#include "tests/support/modbus_test_server.hpp"
#include "tests/unit/modbus/modbus_test_util.hpp"

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
  std::atomic<std::thread::id> poller_thread{};
  Poller poller(test::fast_device(server.port()), points,
                [&](const Event&) { poller_thread.store(std::this_thread::get_id()); });
  poller.start();

  std::vector<PointSample> out(points.size());
  DeviceStatus status;
  auto polls_ok = [&] {
    poller.snapshot(out, monotonic_ns(), &status);
    return status.polls_ok;
  };
  REQUIRE(test::eventually([&] { return polls_ok() >= 2; }));
  REQUIRE(poller_thread.load() != std::thread::id{});

  hvac_twin::test::watch_allocations_of(poller_thread.load());
  // A fault inside the measured window: transport error, COMM_FAIL, back-off, reconnect.
  server.disconnect_clients();
  REQUIRE(test::eventually([&] {
    poller.snapshot(out, monotonic_ns(), &status);
    return status.reconnects == 1 && out[0].quality == PointQuality::kGood;
  }));
  const std::uint64_t target = polls_ok() + 3;
  REQUIRE(test::eventually([&] { return polls_ok() >= target; }));
  CHECK(hvac_twin::test::watched_allocations() == 0);
  CHECK(status.transport_errors == 1);

  const long before = hvac_twin::test::allocations_on_this_thread();
  for (int i = 0; i < 1000; ++i)
    poller.snapshot(out, monotonic_ns(), &status);
  CHECK(hvac_twin::test::allocations_on_this_thread() == before);
  poller.stop();
}
