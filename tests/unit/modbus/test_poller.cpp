// The poller against the real loopback server: qualities, faults, reconnects, stop latency.
#include <arpa/inet.h>
#include <fcntl.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "io/modbus/poller.hpp"
#include "tests/support/modbus_test_server.hpp"
#include "tests/unit/modbus/modbus_test_util.hpp"

using hvac_twin::config::ModbusDeviceConfig;
using hvac_twin::config::PointConfig;
using hvac_twin::config::RegisterKind;
using hvac_twin::config::ValueType;
using hvac_twin::config::WordOrder;
using hvac_twin::test_support::ModbusTestServer;
using hvac_twin::test_support::ModbusTestServerOptions;
using hvac_twin::test_support::ServerFaults;
using namespace hvac_twin::modbus;
using namespace std::chrono_literals;
using test::eventually;

namespace {

// Server + poller + recorded events.
class Rig {
 public:
  explicit Rig(std::vector<PointConfig> points, ModbusTestServerOptions options = {})
      : server(options), points_(std::move(points)) {
    server.start();
    device = test::fast_device(server.port(), options.unit_id);
  }
  ~Rig() {
    if (poller) poller->stop();
  }

  void start() {
    poller = std::make_unique<Poller>(device, points_, [this](const Event& e) {
      std::lock_guard<std::mutex> lock(mutex_);
      events_.push_back({e.kind, std::string(e.message), e.new_quality, e.error_number});
    });
    poller->start();
  }

  PointSample sample(std::size_t i, std::int64_t now = monotonic_ns()) const {
    std::vector<PointSample> out(points_.size());
    poller->snapshot(out, now, nullptr);
    return out.at(i);
  }
  DeviceStatus status() const {
    DeviceStatus s;
    std::vector<PointSample> out(points_.size());
    poller->snapshot(out, monotonic_ns(), &s);
    return s;
  }
  bool all(PointQuality q) const {
    std::vector<PointSample> out(points_.size());
    poller->snapshot(out, monotonic_ns(), nullptr);
    return std::all_of(out.begin(), out.end(),
                       [&](const PointSample& s) { return s.quality == q; });
  }
  bool quality_is(std::size_t i, PointQuality q) const { return sample(i).quality == q; }
  void set(std::size_t i, double value) { server.set_value(points_[i], value); }
  std::size_t count_events(EventKind kind) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return static_cast<std::size_t>(std::count_if(
        events_.begin(), events_.end(), [&](const Recorded& r) { return r.kind == kind; }));
  }
  std::string messages() const {
    std::lock_guard<std::mutex> lock(mutex_);
    std::string all;
    for (const auto& r : events_)
      all += r.message + "\n";
    return all;
  }

  ModbusTestServer server;
  ModbusDeviceConfig device;
  std::unique_ptr<Poller> poller;

 private:
  struct Recorded {
    EventKind kind;
    std::string message;
    PointQuality new_quality;
    int error_number;
  };
  std::vector<PointConfig> points_;
  mutable std::mutex mutex_;
  std::vector<Recorded> events_;
};

std::vector<PointConfig> mixed_points() {
  std::vector<PointConfig> p;
  p.push_back(test::holding("t_supply", 0, ValueType::kFloat32, WordOrder::kABCD));
  p.push_back(test::holding("p_suction", 2, ValueType::kInt16, WordOrder::kBADC));
  p.back().scale = 0.1;
  p.push_back(test::input("energy", 10, ValueType::kUint32, WordOrder::kCDAB));
  p.push_back(test::input("offset", 12, ValueType::kInt32, WordOrder::kDCBA));
  return p;
}

double elapsed_s(std::chrono::steady_clock::time_point since) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - since).count();
}

}  // namespace

TEST_CASE("poller: values arrive GOOD, follow the device, and only reads are sent") {
  Rig rig(mixed_points());
  rig.set(0, 21.5);
  rig.set(1, -12.3);
  rig.set(2, 123456);
  rig.set(3, -2);
  rig.start();
  const PointQuality first = rig.sample(0).quality;  // racing the first poll: either is fine
  CHECK((first == PointQuality::kNotYetRead || first == PointQuality::kGood));
  REQUIRE(eventually([&] { return rig.all(PointQuality::kGood); }));
  CHECK(rig.poller->plan().requests.size() == 2);
  CHECK(rig.sample(0).value == 21.5);
  CHECK(rig.sample(1).value == Approx(-12.3));
  CHECK(rig.sample(2).value == 123456.0);
  CHECK(rig.sample(3).value == -2.0);
  const PointSample s = rig.sample(0);
  CHECK(s.read_time_ns > 0);
  CHECK(s.read_time_ns <= monotonic_ns());
  CHECK(s.exception_code == 0);

  rig.set(0, 22.25);
  CHECK(eventually([&] { return rig.sample(0).value == 22.25; }));

  const DeviceStatus st = rig.status();
  CHECK(st.running);
  CHECK(st.connected);
  CHECK(st.polls_ok >= 1);
  CHECK(st.requests_ok >= 2);
  CHECK(st.transport_errors == 0);
  CHECK(st.last_error[0] == '\0');
  CHECK(rig.count_events(EventKind::kConnected) == 1);

  rig.poller->stop();
  CHECK_FALSE(rig.status().running);
  CHECK_FALSE(rig.status().connected);
  // Read-only: the server saw 0x03 and 0x04 requests and nothing else.
  const auto reads = rig.server.request_count(MODBUS_FC_READ_HOLDING_REGISTERS) +
                     rig.server.request_count(MODBUS_FC_READ_INPUT_REGISTERS);
  CHECK(reads >= 2);
  CHECK(rig.server.total_requests() == reads);
}

TEST_CASE("poller: polls on period deadlines, never faster") {
  Rig rig({test::holding("a", 0)});
  const auto t0 = std::chrono::steady_clock::now();
  rig.start();
  REQUIRE(eventually([&] { return rig.status().polls_ok >= 4; }));
  // The first poll is immediate, the fourth is three periods later at the earliest.
  CHECK(elapsed_s(t0) >= 3 * rig.device.poll_period_s - 0.01);
  CHECK(rig.status().deadline_misses == 0);
}

TEST_CASE("poller: STALE is derived from the age of the last good read at `now`") {
  Rig rig({test::holding("a", 0)});
  rig.set(0, 7);
  rig.start();
  REQUIRE(eventually([&] { return rig.quality_is(0, PointQuality::kGood); }));
  const PointSample s = rig.sample(0);
  const auto stale_ns = static_cast<std::int64_t>(10.0 * 1e9);  // default stale_after_s
  CHECK(rig.sample(0, s.read_time_ns).quality == PointQuality::kGood);
  CHECK(rig.sample(0, s.read_time_ns + stale_ns).quality == PointQuality::kGood);
  const PointSample old = rig.sample(0, s.read_time_ns + stale_ns + 1'000'000'000);
  CHECK(old.quality == PointQuality::kStale);
  CHECK(old.value == 7.0);
}

TEST_CASE("poller: out-of-range and non-finite values are OUT_OF_RANGE, last good value kept") {
  std::vector<PointConfig> points = {test::holding("level", 0, ValueType::kInt16),
                                     test::holding("temp", 1, ValueType::kFloat32)};
  points[0].range_min = 0;
  points[0].range_max = 100;
  Rig rig(points);
  rig.set(0, 50);
  rig.set(1, 20.0);
  rig.start();
  REQUIRE(eventually([&] { return rig.all(PointQuality::kGood); }));

  rig.set(0, 150);
  const std::array<std::uint16_t, 2> nan = {0x7FC0, 0x0000};
  rig.server.set_registers(RegisterKind::kHolding, 1, nan);
  REQUIRE(eventually([&] { return rig.all(PointQuality::kOutOfRange); }));
  CHECK(rig.sample(0).value == 50.0);
  CHECK(rig.sample(1).value == 20.0);
  CHECK(rig.count_events(EventKind::kPointQualityChanged) >= 2);
  CHECK(rig.messages().find("value 150 outside [0, 100]") != std::string::npos);

  rig.set(0, 60);
  rig.set(1, 21.0);
  REQUIRE(eventually([&] { return rig.all(PointQuality::kGood); }));
  CHECK(rig.sample(0).value == 60.0);
  CHECK(rig.status().transport_errors == 0);
}

TEST_CASE("poller: an illegal address marks that request DEVICE_EXCEPTION without reconnect") {
  ModbusTestServerOptions options;
  options.holding_registers = 100;
  Rig rig({test::holding("ok", 10), test::holding("missing", 200)}, options);
  rig.set(0, 5);
  rig.start();
  REQUIRE(eventually([&] {
    return rig.quality_is(0, PointQuality::kGood) &&
           rig.quality_is(1, PointQuality::kDeviceException);
  }));
  CHECK(rig.sample(1).exception_code == MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
  REQUIRE(eventually([&] { return rig.status().polls_exception >= 3; }));
  const DeviceStatus st = rig.status();
  CHECK(st.polls_ok == 0);  // one point failed in every poll
  CHECK(st.exceptions >= 3);
  CHECK(st.transport_errors == 0);
  CHECK(st.reconnects == 0);
  CHECK(rig.server.accepted_connections() == 1);
  CHECK(rig.quality_is(0, PointQuality::kGood));
  CHECK(std::string(st.last_error).find("exception 0x02") != std::string::npos);
}

TEST_CASE("poller: server down -> COMM_FAIL quickly, back up -> GOOD within one back-off cap") {
  Rig rig({test::holding("a", 0), test::input("b", 0, ValueType::kFloat32)});
  rig.set(0, 11);
  rig.set(1, 2.5);
  rig.start();
  REQUIRE(eventually([&] { return rig.all(PointQuality::kGood); }));

  rig.server.stop();
  auto t = std::chrono::steady_clock::now();
  // Noticed at the next poll: one period plus a response timeout, with slack for a loaded host.
  REQUIRE(eventually([&] { return rig.all(PointQuality::kCommFail); }, 3000ms));
  INFO("COMM_FAIL after " << elapsed_s(t) << " s");
  CHECK(rig.sample(0).value == 11.0);  // last value kept
  CHECK(rig.sample(1).value == 2.5);
  CHECK_FALSE(rig.status().connected);
  CHECK(eventually([&] { return rig.status().connect_failures >= 2; }));

  rig.server.start();  // same port
  t = std::chrono::steady_clock::now();
  // Reconnect within backoff_max_s (0.3 s), then the next poll deadline (0.25 s).
  REQUIRE(eventually([&] { return rig.all(PointQuality::kGood); }, 3000ms));
  INFO("GOOD again after " << elapsed_s(t) << " s");
  const DeviceStatus st = rig.status();
  CHECK(st.connected);
  CHECK(st.reconnects == 1);
  CHECK(st.transport_errors == 1);
  CHECK(rig.count_events(EventKind::kDisconnected) == 1);
  CHECK(rig.count_events(EventKind::kConnected) == 2);
  CHECK(rig.count_events(EventKind::kConnectFailed) >= 2);
}

TEST_CASE("poller: a dropped connection costs exactly one failed poll") {
  Rig rig({test::holding("a", 0)});
  rig.start();
  REQUIRE(eventually([&] { return rig.status().polls_ok >= 2; }));
  rig.server.disconnect_clients();
  REQUIRE(eventually([&] { return rig.status().reconnects == 1; }));
  const std::uint64_t ok_before = rig.status().polls_ok;
  REQUIRE(eventually([&] { return rig.status().polls_ok >= ok_before + 2; }));
  const DeviceStatus st = rig.status();
  CHECK(st.polls_failed == 1);
  CHECK(st.transport_errors == 1);
  CHECK(st.connect_failures == 0);
  CHECK(rig.quality_is(0, PointQuality::kGood));
}

TEST_CASE("poller: a reply with the wrong unit id is a desync: COMM_FAIL and reconnect") {
  Rig rig({test::holding("a", 0)});
  rig.set(0, 3);
  rig.start();
  REQUIRE(eventually([&] { return rig.quality_is(0, PointQuality::kGood); }));
  ServerFaults faults;
  faults.reply_unit_id = 2;
  rig.server.set_faults(faults);
  REQUIRE(eventually([&] { return rig.quality_is(0, PointQuality::kCommFail); }));
  DeviceStatus st = rig.status();
  CHECK(st.transport_errors >= 1);
  CHECK(st.last_error_number == kErrUnitId);
  CHECK(std::string(st.last_error).find("unit id") != std::string::npos);
  CHECK(rig.sample(0).value == 3.0);

  rig.server.set_faults({});
  REQUIRE(eventually([&] { return rig.quality_is(0, PointQuality::kGood); }));
  CHECK(rig.status().reconnects >= 1);
  CHECK(rig.server.accepted_connections() >= 2);
}

TEST_CASE("poller: a hung device times out, then recovers") {
  Rig rig({test::holding("a", 0)});
  rig.start();
  REQUIRE(eventually([&] { return rig.quality_is(0, PointQuality::kGood); }));
  ServerFaults faults;
  faults.drop_requests = true;
  rig.server.set_faults(faults);
  REQUIRE(eventually([&] { return rig.quality_is(0, PointQuality::kCommFail); }));
  CHECK(rig.status().last_error_number == ETIMEDOUT);
  rig.server.set_faults({});
  REQUIRE(eventually([&] { return rig.quality_is(0, PointQuality::kGood); }));
}

TEST_CASE("poller: busy (0x06) is retried a bounded number of times") {
  Rig rig({test::holding("a", 0)});
  rig.set(0, 9);
  SECTION("busy once: the retry succeeds") {
    ServerFaults faults;
    faults.forced_exception = MODBUS_EXCEPTION_SLAVE_OR_SERVER_BUSY;
    faults.forced_exception_budget = 1;
    rig.server.set_faults(faults);
    rig.start();
    REQUIRE(eventually([&] { return rig.quality_is(0, PointQuality::kGood); }));
    const DeviceStatus st = rig.status();
    CHECK(st.busy_retries == 1);
    CHECK(st.exceptions == 1);
    CHECK(st.requests_failed == 0);
  }
  SECTION("always busy: DEVICE_EXCEPTION(0x06) after the retries, no reconnect") {
    ServerFaults faults;
    faults.forced_exception = MODBUS_EXCEPTION_SLAVE_OR_SERVER_BUSY;
    rig.server.set_faults(faults);
    rig.start();
    REQUIRE(eventually([&] { return rig.quality_is(0, PointQuality::kDeviceException); }));
    CHECK(rig.sample(0).exception_code == MODBUS_EXCEPTION_SLAVE_OR_SERVER_BUSY);
    REQUIRE(eventually([&] { return rig.status().polls_exception >= 2; }));
    const DeviceStatus st = rig.status();
    CHECK(st.polls_ok == 0);
    CHECK(st.busy_retries == Poller::kBusyRetries * st.requests_failed);
    CHECK(st.transport_errors == 0);
    CHECK(rig.server.accepted_connections() == 1);
  }
}

TEST_CASE("poller: a poll answered with exceptions counts as an exception poll, never as ok") {
  // Issue 17: a device answering every request busy (0x06) raised polls_ok, so the health topic
  // showed the polls "ok" while every point was DEVICE_EXCEPTION.
  Rig rig({test::holding("a", 0), test::input("b", 0)});
  rig.set(0, 4);
  rig.set(1, 5);
  ServerFaults faults;
  faults.forced_exception = MODBUS_EXCEPTION_SLAVE_OR_SERVER_BUSY;
  rig.server.set_faults(faults);
  rig.start();
  REQUIRE(eventually([&] { return rig.status().polls_exception >= 3; }));
  DeviceStatus st = rig.status();
  CHECK(st.polls_ok == 0);
  CHECK(st.polls_failed == 0);
  CHECK(st.last_poll_ok_ns == 0);
  CHECK(rig.all(PointQuality::kDeviceException));
  // Both requests, each sent once and retried kBusyRetries times, in every poll.
  CHECK(st.exceptions >= st.polls_exception * 2 * (Poller::kBusyRetries + 1));

  rig.server.set_faults({});  // the device answers again: ok polls, no more exception polls
  REQUIRE(eventually([&] { return rig.status().polls_ok >= 1; }));
  const std::uint64_t exception_polls = rig.status().polls_exception;
  REQUIRE(eventually([&] { return rig.status().polls_ok >= 3; }));
  st = rig.status();
  CHECK(st.polls_exception == exception_polls);
  CHECK(st.polls_failed == 0);
  CHECK(st.last_poll_ok_ns > 0);
  CHECK(rig.all(PointQuality::kGood));
}

TEST_CASE("poller: gateway exception 0x0B marks every point, keeps the connection") {
  // The server is unit 1; the device config asks for unit 2 behind this "gateway".
  Rig rig({test::holding("a", 0), test::input("b", 50)});
  rig.device.unit_id = 2;
  rig.start();
  REQUIRE(eventually([&] { return rig.all(PointQuality::kDeviceException); }));
  CHECK(rig.sample(0).exception_code == MODBUS_EXCEPTION_GATEWAY_TARGET);
  CHECK(rig.sample(1).exception_code == MODBUS_EXCEPTION_GATEWAY_TARGET);
  REQUIRE(eventually([&] { return rig.status().polls_failed >= 2; }));
  const DeviceStatus st = rig.status();
  CHECK(st.polls_ok == 0);
  CHECK(st.polls_exception == 0);  // a gateway failure fails the poll
  CHECK(st.transport_errors == 0);
  CHECK(st.connected);
  CHECK(rig.server.accepted_connections() == 1);
  // The rest of a poll is skipped after a gateway failure: one request per poll.
  CHECK(rig.server.request_count(MODBUS_FC_READ_INPUT_REGISTERS) == 0);
}

TEST_CASE("poller: stop() is prompt while waiting for a deadline or backing off") {
  SECTION("waiting for the next poll") {
    Rig rig({test::holding("a", 0)});
    rig.device.poll_period_s = 10.0;
    rig.start();
    REQUIRE(eventually([&] { return rig.quality_is(0, PointQuality::kGood); }));
    const auto t0 = std::chrono::steady_clock::now();
    rig.poller->stop();
    INFO("stop took " << elapsed_s(t0) << " s");
    CHECK(elapsed_s(t0) < 0.5);
  }
  SECTION("backing off from a refused device") {
    Rig rig({test::holding("a", 0)});
    rig.device.poll_period_s = 10.0;
    rig.device.backoff_initial_s = 5.0;
    rig.device.backoff_max_s = 5.0;
    rig.server.stop();
    rig.start();
    REQUIRE(eventually([&] { return rig.status().connect_failures >= 1; }));
    CHECK(rig.quality_is(0, PointQuality::kCommFail));
    CHECK(rig.status().last_error_number == ECONNREFUSED);
    const auto t0 = std::chrono::steady_clock::now();
    rig.poller->stop();
    INFO("stop took " << elapsed_s(t0) << " s");
    CHECK(elapsed_s(t0) < 0.5);
  }
}

TEST_CASE("poller: a connect to a black-holed port is bounded by the response timeout") {
  // A loopback black hole: a listener with backlog 0 whose accept queue is already full drops
  // further SYNs, so connect() neither succeeds nor is refused.
  const int listener = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  REQUIRE(listener >= 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof addr;
  REQUIRE(::bind(listener, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0);
  REQUIRE(::listen(listener, 0) == 0);
  REQUIRE(::getsockname(listener, reinterpret_cast<sockaddr*>(&addr), &len) == 0);
  std::vector<int> fillers;
  for (int i = 0; i < 2; ++i) {
    const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    REQUIRE(fd >= 0);
    (void)::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr);
    fillers.push_back(fd);
  }

  std::vector<PointConfig> points = {test::holding("a", 0)};
  ModbusDeviceConfig device = test::fast_device(ntohs(addr.sin_port));
  device.response_timeout_s = 0.3;
  device.poll_period_s = 1.0;
  device.backoff_initial_s = 5.0;
  device.backoff_max_s = 5.0;
  Poller poller(device, points);
  const auto t0 = std::chrono::steady_clock::now();
  poller.start();
  DeviceStatus st;
  std::vector<PointSample> out(1);
  REQUIRE(eventually([&] {
    poller.snapshot(out, monotonic_ns(), &st);
    return st.connect_failures >= 1;
  }));
  const double took = elapsed_s(t0);
  INFO("first connect attempt failed after " << took << " s");
  CHECK(took >= 0.25);  // it really waited: the SYN was dropped, not refused
  CHECK(took < 2.0);
  // libmodbus 3.1.6 reports a connect timeout with the errno of connect(): EINPROGRESS.
  CHECK((st.last_error_number == EINPROGRESS || st.last_error_number == ETIMEDOUT));
  CHECK(out[0].quality == PointQuality::kCommFail);
  const auto t1 = std::chrono::steady_clock::now();
  poller.stop();
  CHECK(elapsed_s(t1) < 0.5);
  for (int fd : fillers)
    ::close(fd);
  ::close(listener);
}

TEST_CASE("poller: snapshot before start, partial spans, no status") {
  Rig rig({test::holding("a", 0), test::holding("b", 1)});
  rig.start();
  rig.poller->stop();
  std::vector<PointSample> one(1);
  CHECK(rig.poller->snapshot(one, monotonic_ns(), nullptr) == 1);
  std::vector<PointSample> many(5);
  CHECK(rig.poller->snapshot(many, monotonic_ns(), nullptr) == 2);
  CHECK(rig.poller->snapshot({}, monotonic_ns(), nullptr) == 0);
  CHECK(rig.poller->point_count() == 2);

  Poller idle(rig.device, std::vector<PointConfig>{test::holding("x", 0)});
  DeviceStatus st;
  CHECK(idle.snapshot(one, monotonic_ns(), &st) == 1);
  CHECK(one[0].quality == PointQuality::kNotYetRead);
  CHECK_FALSE(st.running);
  CHECK(st.connect_attempts == 0);
  idle.stop();  // stop without start is fine
}

TEST_CASE("poller: the constructor rejects bad configurations") {
  const ModbusDeviceConfig good = test::fast_device(1502);
  const std::vector<PointConfig> points = {test::holding("a", 0)};
  CHECK_NOTHROW(Poller(good, points));

  auto bad_device = [&](auto edit) {
    ModbusDeviceConfig d = good;
    edit(d);
    CHECK_THROWS_AS(Poller(d, points), std::invalid_argument);
  };
  bad_device([](ModbusDeviceConfig& d) { d.response_timeout_s = d.poll_period_s / 2; });
  bad_device([](ModbusDeviceConfig& d) { d.byte_timeout_s = 0; });
  bad_device([](ModbusDeviceConfig& d) { d.poll_period_s = std::nan(""); });
  bad_device([](ModbusDeviceConfig& d) { d.backoff_initial_s = 0; });
  bad_device([](ModbusDeviceConfig& d) { d.backoff_max_s = d.backoff_initial_s / 2; });
  bad_device([](ModbusDeviceConfig& d) { d.max_registers_per_request = 126; });
  bad_device([](ModbusDeviceConfig& d) { d.unit_id = -1; });

  auto bad_point = [&](auto edit) {
    std::vector<PointConfig> p = points;
    edit(p[0]);
    CHECK_THROWS_AS(Poller(good, p), std::invalid_argument);
  };
  bad_point([](PointConfig& p) { p.word_order = WordOrder::kCDAB; });  // int16 default type
  bad_point([](PointConfig& p) { p.scale = 0; });
  bad_point([](PointConfig& p) { p.offset = std::numeric_limits<double>::infinity(); });
  bad_point([](PointConfig& p) { p.range_min = 2, p.range_max = 1; });
  bad_point([](PointConfig& p) { p.stale_after_s = 0; });
  bad_point([](PointConfig& p) { p.address = 65535, p.type = ValueType::kFloat32; });
  CHECK_THROWS_AS(Poller(good, std::vector<PointConfig>{}), std::invalid_argument);
}
