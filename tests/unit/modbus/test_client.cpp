// The libmodbus client wrapper: reply validation (pure) and reads against the loopback server.
#include <modbus/modbus.h>

#include <array>
#include <catch2/catch.hpp>
#include <cerrno>
#include <cstring>
#include <vector>

#include "io/modbus/client.hpp"
#include "tests/support/modbus_test_server.hpp"
#include "tests/unit/modbus/modbus_test_util.hpp"

using hvac_twin::config::RegisterKind;
using hvac_twin::test_support::ModbusTestServer;
using hvac_twin::test_support::ModbusTestServerOptions;
using hvac_twin::test_support::ServerFaults;
using hvac_twin::test_support::UnitIdPolicy;
using namespace hvac_twin::modbus;

namespace {

using Bytes = std::vector<std::uint8_t>;

// A well-formed reply to "read 2 holding registers" from unit 5 with transaction id 0x0102.
Bytes good_reply() {
  return {0x01, 0x02, 0, 0, 0, 7, 5, 0x03, 4, 0x12, 0x34, 0xAB, 0xCD};
}

ReadResult check(const Bytes& adu, std::array<std::uint16_t, 2>& out) {
  return check_reply(adu, 0x0102, 5, 0x03, 2, out);
}

}  // namespace

TEST_CASE("check_reply accepts exactly the reply to our request") {
  std::array<std::uint16_t, 2> out{};
  ReadResult r = check(good_reply(), out);
  CHECK(r.outcome == ReadOutcome::kOk);
  CHECK(out[0] == 0x1234);
  CHECK(out[1] == 0xABCD);

  const Bytes exception = {0x01, 0x02, 0, 0, 0, 3, 5, 0x83, 0x02};
  r = check(exception, out);
  CHECK(r.outcome == ReadOutcome::kException);
  CHECK(r.exception_code == 0x02);

  auto expect_transport = [&](Bytes adu, int error) {
    const ReadResult bad = check(adu, out);
    CHECK(bad.outcome == ReadOutcome::kTransportError);
    CHECK(bad.error_number == error);
  };
  Bytes b = good_reply();
  b[6] = 6;  // another unit
  expect_transport(b, kErrUnitId);
  b = good_reply();
  b[1] = 0x03;  // another transaction
  expect_transport(b, kErrTransactionId);
  b = good_reply();
  b[3] = 1;
  expect_transport(b, kErrProtocolId);
  b = good_reply();
  b[5] = 8;
  expect_transport(b, kErrLengthField);
  b = good_reply();
  b[7] = 0x04;  // input registers answer to a holding request
  expect_transport(b, kErrFunction);
  b = good_reply();
  b[8] = 2;
  expect_transport(b, kErrByteCount);
  b = {0x01, 0x02, 0, 0, 0, 3, 5, 0x83, 0x00};
  expect_transport(b, kErrBadException);
  b = good_reply();
  b.resize(8);
  expect_transport(b, kErrShortReply);
  CHECK(std::strstr(error_text(kErrUnitId), "unit id") != nullptr);
  CHECK(std::strcmp(error_text(ETIMEDOUT), "Connection timed out") == 0);
}

TEST_CASE("client reads holding and input registers, exceptions keep the connection") {
  ModbusTestServerOptions options;
  options.unit_id = 3;
  options.holding_registers = 100;
  ModbusTestServer server(options);
  server.start();
  const std::array<std::uint16_t, 4> h = {10, 11, 12, 13};
  const std::array<std::uint16_t, 2> in = {0xFFFF, 0x8000};
  server.set_registers(RegisterKind::kHolding, 50, h);
  server.set_registers(RegisterKind::kInput, 7, in);

  Client client(test::fast_device(server.port(), 3));
  CHECK_FALSE(client.is_connected());
  REQUIRE(client.connect() == 0);
  REQUIRE(client.is_connected());
  std::array<std::uint16_t, 125> regs{};
  ReadResult r = client.read(RegisterKind::kHolding, 50, 4, regs);
  REQUIRE(r.outcome == ReadOutcome::kOk);
  CHECK(std::equal(h.begin(), h.end(), regs.begin()));
  r = client.read(RegisterKind::kInput, 7, 2, regs);
  REQUIRE(r.outcome == ReadOutcome::kOk);
  CHECK(regs[0] == 0xFFFF);
  CHECK(regs[1] == 0x8000);

  r = client.read(RegisterKind::kHolding, 99, 2, regs);  // past the 100 served registers
  CHECK(r.outcome == ReadOutcome::kException);
  CHECK(r.exception_code == MODBUS_EXCEPTION_ILLEGAL_DATA_ADDRESS);
  r = client.read(RegisterKind::kHolding, 50, 125, regs);  // 50 + 125 > 100 as well
  CHECK(r.outcome == ReadOutcome::kException);
  r = client.read(RegisterKind::kHolding, 50, 1, regs);  // same connection still in sync
  CHECK(r.outcome == ReadOutcome::kOk);
  CHECK(server.accepted_connections() == 1);

  CHECK(client.read(RegisterKind::kHolding, 0, 0, regs).error_number == EINVAL);
  CHECK(client.read(RegisterKind::kHolding, 0, 126, regs).error_number == EINVAL);
  CHECK(client.read(RegisterKind::kHolding, 65535, 2, regs).error_number == EINVAL);

  // Read-only: nothing but 0x03 and 0x04 ever reached the server.
  CHECK(server.total_requests() == server.request_count(MODBUS_FC_READ_HOLDING_REGISTERS) +
                                       server.request_count(MODBUS_FC_READ_INPUT_REGISTERS));
  client.close();
  CHECK_FALSE(client.is_connected());
  CHECK(client.read(RegisterKind::kHolding, 50, 1, regs).error_number == EBADF);
}

TEST_CASE("libmodbus alone accepts a reply from the wrong unit id, our client rejects it") {
  ModbusTestServer server;  // unit 1
  server.start();
  const std::array<std::uint16_t, 1> v = {1234};
  server.set_registers(RegisterKind::kHolding, 0, v);
  ServerFaults faults;
  faults.reply_unit_id = 42;  // the server answers as unit 42
  server.set_faults(faults);

  // The premise (shared/reliability.md): modbus_read_registers() does not look at the unit id.
  modbus_t* plain = modbus_new_tcp("127.0.0.1", server.port());
  REQUIRE(plain != nullptr);
  modbus_set_slave(plain, 1);
  modbus_set_response_timeout(plain, 0, 300'000);
  REQUIRE(modbus_connect(plain) == 0);
  std::uint16_t value = 0;
  CHECK(modbus_read_registers(plain, 0, 1, &value) == 1);
  CHECK(value == 1234);
  modbus_close(plain);
  modbus_free(plain);

  Client client(test::fast_device(server.port(), 1));
  REQUIRE(client.connect() == 0);
  std::array<std::uint16_t, 1> regs{};
  const ReadResult r = client.read(RegisterKind::kHolding, 0, 1, regs);
  CHECK(r.outcome == ReadOutcome::kTransportError);
  CHECK(r.error_number == kErrUnitId);

  server.set_faults({});
  REQUIRE(client.connect() == 0);
  CHECK(client.read(RegisterKind::kHolding, 0, 1, regs).outcome == ReadOutcome::kOk);
  CHECK(regs[0] == 1234);
}

TEST_CASE("client: desynchronised, lost and refused replies are transport errors") {
  ModbusTestServer server;
  server.start();
  Client client(test::fast_device(server.port(), 1));
  REQUIRE(client.connect() == 0);
  std::array<std::uint16_t, 2> regs{};

  ServerFaults faults;
  faults.transaction_id_delta = -1;  // looks like the reply to the previous request
  server.set_faults(faults);
  ReadResult r = client.read(RegisterKind::kHolding, 0, 2, regs);
  CHECK(r.outcome == ReadOutcome::kTransportError);
  CHECK(r.error_number == kErrTransactionId);

  faults = {};
  faults.drop_requests = true;
  server.set_faults(faults);
  REQUIRE(client.connect() == 0);
  r = client.read(RegisterKind::kHolding, 0, 2, regs);
  CHECK(r.outcome == ReadOutcome::kTransportError);
  CHECK(r.error_number == ETIMEDOUT);

  server.set_faults({});
  server.disconnect_clients();
  CHECK(test::eventually([&] { return server.client_count() == 0; }));
  r = client.read(RegisterKind::kHolding, 0, 2, regs);
  CHECK(r.outcome == ReadOutcome::kTransportError);  // EOF/reset on a stale connection

  const std::uint16_t port = server.port();
  server.stop();
  Client refused(test::fast_device(port, 1));
  CHECK(refused.connect() == ECONNREFUSED);
  CHECK_FALSE(refused.is_connected());
}

TEST_CASE("client constructor validates the device") {
  auto device = test::fast_device(1502, 1);
  device.unit_id = 256;
  CHECK_THROWS_AS(Client(device), std::invalid_argument);
  device = test::fast_device(1502, 1);
  device.byte_timeout_s = 0.0;  // libmodbus would wait forever for the rest of a reply
  CHECK_THROWS_AS(Client(device), std::invalid_argument);
  device = test::fast_device(0, 1);
  CHECK_THROWS_AS(Client(device), std::invalid_argument);
  device = test::fast_device(1502, 255);
  CHECK_NOTHROW(Client(device));  // unit ids 248..255 are legal on TCP
}
