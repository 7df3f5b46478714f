// The loopback test server itself, exercised with a plain libmodbus client.
#include <modbus/modbus.h>

#include <array>
#include <catch2/catch.hpp>
#include <cerrno>
#include <chrono>
#include <memory>
#include <vector>

#include "tests/support/modbus_test_server.hpp"
#include "tests/unit/modbus/modbus_test_util.hpp"

using hvac_twin::config::RegisterKind;
using hvac_twin::test_support::ModbusTestServer;
using hvac_twin::test_support::ModbusTestServerOptions;
using hvac_twin::test_support::ServerFaults;
using hvac_twin::test_support::UnitIdPolicy;

namespace {

// A plain libmodbus client (what a third-party master would do).
struct PlainClient {
  modbus_t* ctx;
  PlainClient(std::uint16_t port, int unit_id) : ctx(modbus_new_tcp("127.0.0.1", port)) {
    REQUIRE(ctx != nullptr);
    modbus_set_slave(ctx, unit_id);
    modbus_set_response_timeout(ctx, 0, 300'000);
    modbus_set_byte_timeout(ctx, 0, 100'000);
  }
  ~PlainClient() {
    modbus_close(ctx);
    modbus_free(ctx);
  }
  PlainClient(const PlainClient&) = delete;
  PlainClient& operator=(const PlainClient&) = delete;
  bool connect() { return modbus_connect(ctx) == 0; }
};

}  // namespace

TEST_CASE("test server: ephemeral port, holding and input registers") {
  ModbusTestServerOptions options;
  options.holding_registers = 1024;
  options.input_registers = 1024;
  ModbusTestServer server(options);
  server.start();
  REQUIRE(server.running());
  REQUIRE(server.port() != 0);
  const std::array<std::uint16_t, 3> h = {1, 2, 3};
  const std::array<std::uint16_t, 2> in = {0xBEEF, 0xCAFE};
  server.set_registers(RegisterKind::kHolding, 10, h);
  server.set_registers(RegisterKind::kInput, 20, in);

  PlainClient client(server.port(), 1);
  REQUIRE(client.connect());
  std::array<std::uint16_t, 3> got{};
  REQUIRE(modbus_read_registers(client.ctx, 10, 3, got.data()) == 3);
  CHECK(got == h);
  REQUIRE(modbus_read_input_registers(client.ctx, 20, 2, got.data()) == 2);
  CHECK(got[0] == 0xBEEF);
  CHECK(got[1] == 0xCAFE);
  // Beyond the served addresses: exception 0x02.
  CHECK(modbus_read_registers(client.ctx, 1023, 2, got.data()) == -1);
  CHECK(errno == EMBXILADD);

  CHECK(server.request_count(MODBUS_FC_READ_HOLDING_REGISTERS) == 2);
  CHECK(server.request_count(MODBUS_FC_READ_INPUT_REGISTERS) == 1);
  CHECK(modbus_write_register(client.ctx, 5, 77) == 1);  // the test server accepts writes...
  CHECK(server.request_count(MODBUS_FC_WRITE_SINGLE_REGISTER) == 1);  // ...and counts them
  CHECK(server.total_requests() == 4);

  std::array<std::uint16_t, 1> back{};
  server.get_registers(RegisterKind::kHolding, 5, back);
  CHECK(back[0] == 77);
  CHECK_THROWS_AS(server.set_registers(RegisterKind::kInput, 1023, h), std::out_of_range);
}

TEST_CASE("test server: several clients at once, stop and restart on the same port") {
  ModbusTestServer server;
  server.start();
  const std::uint16_t port = server.port();
  const std::array<std::uint16_t, 1> v = {42};
  server.set_registers(RegisterKind::kHolding, 0, v);

  std::vector<std::unique_ptr<PlainClient>> clients;
  for (int i = 0; i < 3; ++i) {
    clients.push_back(std::make_unique<PlainClient>(port, 1));
    REQUIRE(clients.back()->connect());
  }
  for (int round = 0; round < 3; ++round) {
    for (auto& c : clients) {
      std::uint16_t r = 0;
      REQUIRE(modbus_read_registers(c->ctx, 0, 1, &r) == 1);
      CHECK(r == 42);
    }
  }
  CHECK(hvac_twin::modbus::test::eventually([&] { return server.client_count() == 3; }));

  const auto t0 = std::chrono::steady_clock::now();
  server.stop();
  CHECK(std::chrono::steady_clock::now() - t0 < std::chrono::milliseconds(1000));
  CHECK_FALSE(server.running());
  std::uint16_t r = 0;
  CHECK(modbus_read_registers(clients[0]->ctx, 0, 1, &r) == -1);  // connection gone

  server.start();  // same port, at once (SO_REUSEADDR despite TIME_WAIT)
  CHECK(server.port() == port);
  PlainClient again(port, 1);
  REQUIRE(again.connect());
  REQUIRE(modbus_read_registers(again.ctx, 0, 1, &r) == 1);
  CHECK(r == 42);  // registers survive a restart
  CHECK(server.accepted_connections() == 4);
}

TEST_CASE("test server: unit id policies") {
  SECTION("default: another unit id gets exception 0x0B") {
    ModbusTestServer server({0, 7});
    server.start();
    PlainClient client(server.port(), 8);
    REQUIRE(client.connect());
    std::uint16_t r = 0;
    CHECK(modbus_read_registers(client.ctx, 0, 1, &r) == -1);
    CHECK(errno == EMBXGTAR);
    modbus_set_slave(client.ctx, 7);
    CHECK(modbus_read_registers(client.ctx, 0, 1, &r) == 1);
  }
  SECTION("ignore: no reply, the client times out") {
    ModbusTestServerOptions options;
    options.unit_id = 7;
    options.unit_id_policy = UnitIdPolicy::kIgnore;
    ModbusTestServer server(options);
    server.start();
    PlainClient client(server.port(), 8);
    REQUIRE(client.connect());
    std::uint16_t r = 0;
    CHECK(modbus_read_registers(client.ctx, 0, 1, &r) == -1);
    CHECK(errno == ETIMEDOUT);
  }
  SECTION("answer any") {
    ModbusTestServerOptions options;
    options.unit_id = 7;
    options.unit_id_policy = UnitIdPolicy::kAnswerAny;
    ModbusTestServer server(options);
    server.start();
    PlainClient client(server.port(), 8);
    REQUIRE(client.connect());
    std::uint16_t r = 0;
    CHECK(modbus_read_registers(client.ctx, 0, 1, &r) == 1);
  }
}

TEST_CASE("test server: fault injection and dropping clients") {
  ModbusTestServer server;
  server.start();
  PlainClient client(server.port(), 1);
  REQUIRE(client.connect());
  std::uint16_t r = 0;

  ServerFaults busy_twice;
  busy_twice.forced_exception = MODBUS_EXCEPTION_SLAVE_OR_SERVER_BUSY;
  busy_twice.forced_exception_budget = 2;
  server.set_faults(busy_twice);
  CHECK(modbus_read_registers(client.ctx, 0, 1, &r) == -1);
  CHECK(errno == EMBXSBUSY);
  CHECK(modbus_read_registers(client.ctx, 0, 1, &r) == -1);
  CHECK(modbus_read_registers(client.ctx, 0, 1, &r) == 1);  // budget spent

  ServerFaults wrong_tid;
  wrong_tid.transaction_id_delta = 1;
  server.set_faults(wrong_tid);
  CHECK(modbus_read_registers(client.ctx, 0, 1, &r) == -1);  // libmodbus checks the tid
  server.set_faults({});
  modbus_close(client.ctx);
  REQUIRE(client.connect());
  CHECK(modbus_read_registers(client.ctx, 0, 1, &r) == 1);

  server.disconnect_clients();
  CHECK(hvac_twin::modbus::test::eventually([&] { return server.client_count() == 0; }));
  CHECK(modbus_read_registers(client.ctx, 0, 1, &r) == -1);
}
