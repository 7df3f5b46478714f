// The Modbus client and poller against the fault-injection server: every fault is detected,
// no broken reply is ever taken as data, a fault costs the poller at most one failed poll, and a
// black-holed connect is bounded by the response timeout.
#include <catch2/catch.hpp>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <vector>

#include "io/modbus/client.hpp"
#include "io/modbus/poller.hpp"
#include "tests/fault/fault_server.hpp"
#include "tests/unit/modbus/modbus_test_util.hpp"

using hvac_twin::config::PointConfig;
using hvac_twin::config::RegisterKind;
using hvac_twin::config::ValueType;
using hvac_twin::config::WordOrder;
using namespace hvac_twin::modbus;
using namespace hvac_twin::test_fault;
using namespace std::chrono_literals;

namespace {

// Points with a good value the server serves and a poison value only broken replies carry.
struct Served {
  PointConfig point;
  double good, poison;
};

std::vector<Served> served() {
  auto scaled = test::holding("a", 0, ValueType::kInt16);
  scaled.scale = 0.01;
  return {{scaled, 21.0, 44.44},
          {test::holding("b", 1, ValueType::kUint16), 1234.0, 4444.0},
          {test::input("c", 0, ValueType::kFloat32, WordOrder::kCDAB), 3.25, 44.5},
          {test::input("d", 2, ValueType::kInt32), -100000.0, 444444.0}};
}

void serve(FaultServer& server, const std::vector<Served>& points) {
  for (const auto& s : points) {
    REQUIRE(server.set_value(s.point, s.good) == EncodeStatus::kOk);
    REQUIRE(server.set_value(s.point, s.poison, true) == EncodeStatus::kOk);
  }
}

bool near(double a, double b) {
  return std::abs(a - b) <= 1e-9 * std::max(1.0, std::abs(b));
}

hvac_twin::config::ModbusDeviceConfig device_for(const FaultServer& server) {
  auto d = test::fast_device(server.port());
  d.poll_period_s = 0.1;
  d.response_timeout_s = 0.04;
  d.byte_timeout_s = 0.02;
  d.backoff_initial_s = 0.02;  // well below the poll period: one failed poll per fault
  d.backoff_max_s = 0.5;
  return d;
}

const std::vector<Fault> kRequestFaults = {
    {FaultKind::kResetOnRequest},     {FaultKind::kFinOnRequest}, {FaultKind::kGarbage},
    {FaultKind::kWrongTransactionId}, {FaultKind::kWrongUnitId},  {FaultKind::kWrongFunction},
    {FaultKind::kBadProtocolId},      {FaultKind::kShortFrame},   {FaultKind::kShortPdu},
    {FaultKind::kLateReply},          {FaultKind::kNoReply}};

}  // namespace

TEST_CASE("client: every broken reply is a transport error and never data", "[fault]") {
  FaultServer server(FaultServerOptions{.late_reply_delay = 100ms});
  const auto points = served();
  serve(server, points);
  server.start();
  Client client(device_for(server));
  std::vector<std::uint16_t> regs(2);
  const std::uint16_t good_a = 2100, poison_a = 4444;  // register "a" (int16, scale 0.01)

  for (const Fault& f : kRequestFaults) {
    INFO("fault: " << to_string(f.kind));
    REQUIRE(client.connect() == 0);
    REQUIRE(client.read(RegisterKind::kHolding, 0, 2, regs).outcome == ReadOutcome::kOk);
    CHECK(regs[0] == good_a);
    server.inject(f);
    regs.assign(2, 0);
    const ReadResult r = client.read(RegisterKind::kHolding, 0, 2, regs);
    INFO("error: " << error_text(r.error_number));
    CHECK(r.outcome == ReadOutcome::kTransportError);
    CHECK(regs[0] != poison_a);
    CHECK(server.applied(f.kind) == 1);
    client.close();
  }

  SECTION("a duplicated reply desynchronises the next read, which is refused") {
    REQUIRE(client.connect() == 0);
    server.inject({FaultKind::kDuplicateReply});
    REQUIRE(client.read(RegisterKind::kHolding, 0, 2, regs).outcome == ReadOutcome::kOk);
    CHECK(regs[0] == good_a);
    const ReadResult r = client.read(RegisterKind::kHolding, 0, 2, regs);
    CHECK(r.outcome == ReadOutcome::kTransportError);
    CHECK(r.error_number == kErrTransactionId);
    CHECK(regs[0] == good_a);  // untouched
  }
  SECTION("exceptions arrive as exceptions, the connection stays usable") {
    REQUIRE(client.connect() == 0);
    for (const int code : {0x02, 0x04, 0x06, 0x0B}) {
      server.inject({FaultKind::kException, static_cast<std::uint8_t>(code)});
      const ReadResult r = client.read(RegisterKind::kHolding, 0, 2, regs);
      CHECK(r.outcome == ReadOutcome::kException);
      CHECK(r.exception_code == code);
    }
    CHECK(client.read(RegisterKind::kHolding, 0, 2, regs).outcome == ReadOutcome::kOk);
  }
  SECTION("RST and FIN between requests fail the next read") {
    for (const FaultKind kind : {FaultKind::kResetIdle, FaultKind::kFinIdle}) {
      // Wait for the server to have accepted this connection, not only for a count of one: the
      // connection closed before (above, or the previous kind's) may still be counted, and an
      // idle fault the server takes while it holds no client is dropped (once in a CI run: the
      // reset never applied, the read answered).
      const auto accepted = server.accepted_connections();
      REQUIRE(client.connect() == 0);
      REQUIRE(test::eventually([&] {
        return server.accepted_connections() == accepted + 1 && server.client_count() == 1;
      }));
      server.inject({kind});
      REQUIRE(test::eventually([&] { return server.client_count() == 0; }));
      std::this_thread::sleep_for(10ms);  // let the RST/FIN reach the client's socket
      const ReadResult r = client.read(RegisterKind::kHolding, 0, 2, regs);
      INFO(to_string(kind) << ": " << error_text(r.error_number));
      CHECK(r.outcome == ReadOutcome::kTransportError);
      CHECK(server.applied(kind) == 1);
    }
  }
  CHECK(server.requests(0x06) + server.requests(0x10) + server.requests(0x05) == 0);
}

TEST_CASE("poller: at most one failed poll per fault, and no poisoned value ever", "[fault]") {
  FaultServer server(FaultServerOptions{.late_reply_delay = 100ms, .seed = 7});
  const auto points = served();
  serve(server, points);
  server.start();
  std::vector<PointConfig> configs;
  for (const auto& s : points)
    configs.push_back(s.point);
  Poller poller(device_for(server), configs);
  poller.start();

  std::vector<PointSample> snap(points.size());
  DeviceStatus st;
  const auto look = [&] {
    poller.snapshot(snap, monotonic_ns(), &st);
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (snap[i].read_time_ns == 0) continue;  // never read: value 0
      if (!near(snap[i].value, points[i].good)) return false;
    }
    return true;
  };
  bool clean = true;
  const auto good_polls_after = [&](std::uint64_t ok) {
    return test::eventually([&] {
      clean = look() && clean;
      return st.polls_ok >= ok;
    });
  };
  REQUIRE(good_polls_after(2));

  std::vector<Fault> faults = kRequestFaults;
  faults.push_back({FaultKind::kDuplicateReply});
  faults.push_back({FaultKind::kResetIdle});
  faults.push_back({FaultKind::kFinIdle});
  for (const int code : {0x02, 0x04, 0x06, 0x0A, 0x0B})
    faults.push_back({FaultKind::kException, static_cast<std::uint8_t>(code)});
  const std::uint64_t failed_before = st.polls_failed;
  std::size_t rounds = 0;
  for (int round = 0; round < 2; ++round) {
    for (const Fault& f : faults) {
      INFO("fault: " << to_string(f.kind) << " code " << int{f.exception_code});
      const std::uint64_t applied = server.applied_total();
      server.inject(f);
      REQUIRE(test::eventually([&] { return server.applied_total() == applied + 1; }));
      // Recovered: two polls without any failure after the fault took effect.
      const std::uint64_t ok = st.polls_ok;
      REQUIRE(good_polls_after(ok + 2));
      ++rounds;
    }
  }
  poller.stop();
  const std::uint64_t failed = st.polls_failed - failed_before;
  INFO("faults " << rounds << ", failed polls " << failed << ", transport errors "
                 << st.transport_errors << ", reconnects " << st.reconnects);
  CHECK(clean);
  CHECK(failed <= rounds);
  // Every fault but exceptions 0x02/0x04 (a point fault) and one 0x06 (retried) fails its poll.
  CHECK(failed >= rounds - 2 * 3);
  CHECK(st.reconnects <= rounds);
  CHECK(server.requests(0x06) + server.requests(0x10) == 0);
}

TEST_CASE("a black-holed connect times out after the response timeout, then recovers", "[fault]") {
  FaultServer server;
  server.start();
  auto device = test::fast_device(server.port());
  device.response_timeout_s = 0.2;
  Client client(device);
  REQUIRE(client.connect() == 0);
  client.close();
  server.set_black_hole(true);
  for (int i = 0; i < 3; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const int e = client.connect();
    const double took =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    INFO("connect " << i << ": " << error_text(e) << " after " << took << " s");
    CHECK((e == EINPROGRESS || e == ETIMEDOUT));
    CHECK(took >= 0.15);  // really waited: the SYN was dropped, not refused
    CHECK(took < 1.0);
  }
  server.set_black_hole(false);
  REQUIRE(test::eventually([&] { return client.connect() == 0; }, 3000ms));
  std::vector<std::uint16_t> regs(1);
  CHECK(client.read(RegisterKind::kHolding, 0, 1, regs).outcome == ReadOutcome::kOk);
}
