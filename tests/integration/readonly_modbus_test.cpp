// Read-only on the wire: the real hvac-twind polls a Modbus test server that counts every request
// by function code. Over many polls of holding (0x03) and input (0x04) registers, those two are
// the only codes it receives. The same counters register a write at once (so the test can fail).
#include <modbus/modbus.h>

#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>

#include "tests/integration/stack.hpp"
#include "tests/support/modbus_test_server.hpp"

using namespace hvac_twin::test;
using namespace std::chrono_literals;
using hvac_twin::config::PointConfig;
using hvac_twin::config::RegisterKind;
using hvac_twin::test_support::ModbusTestServer;

namespace {

// "0x03: 42" for every function code received, one per line.
std::string function_code_log(const ModbusTestServer& server) {
  std::string out;
  for (int fc = 0; fc < 256; ++fc) {
    const auto n = server.request_count(static_cast<std::uint8_t>(fc));
    if (n == 0) continue;
    char line[32];
    std::snprintf(line, sizeof line, "0x%02X: %llu\n", fc, static_cast<unsigned long long>(n));
    out += line;
  }
  return out;
}

}  // namespace

TEST_CASE("hvac-twind sends only read function codes to its Modbus device",
          "[integration][readonly]") {
  ModbusTestServer server;
  server.start();
  // zone_temp is an input register (0x04); outdoor_temp is moved to a holding register (0x03).
  PointConfig zone;
  zone.kind = RegisterKind::kInput;
  zone.address = 0;
  zone.type = hvac_twin::config::ValueType::kInt16;
  zone.scale = 0.01;
  REQUIRE(server.set_value(zone, 21.5) == hvac_twin::modbus::EncodeStatus::kOk);
  PointConfig outdoor = zone;
  outdoor.kind = RegisterKind::kHolding;
  outdoor.address = 1;
  outdoor.scale = 0.1;
  REQUIRE(server.set_value(outdoor, 4.0) == hvac_twin::modbus::EncodeStatus::kOk);

  StackOptions o;
  o.domain_id = 62;
  o.time_scale = 60.0;
  o.period_s = 12.0;  // 0.2 s wall
  o.poll_period_s = 0.05;
  const std::uint16_t port = server.port();
  o.customize = [port](nlohmann::json& c) {
    c["units"][0]["modbus"]["port"] = port;
    c["units"][0]["points"][1]["register"] = "holding";
  };
  Stack stack("readonly", o);
  stack.start_daemon();
  stack.start_echo(30.0);

  // Many polls of both register kinds, and the values read arrive as observations.
  REQUIRE(eventually(
      [&] { return server.request_count(0x03) >= 40 && server.request_count(0x04) >= 40; }, 20s));
  const bool read_back = eventually(
      [&] {
        for (const auto& s : stack.samples())
          if (s["topic"] == "observation" && s["point"] == "zone_temp" && s["quality"] == "GOOD" &&
              std::abs(s["value"].get<double>() - 21.5) < 1e-9)
            return true;
        return false;
      },
      10s);
  CHECK(read_back);
  stack.daemon().signal(SIGTERM);
  REQUIRE(stack.daemon().wait(5s) == 0);  // shut-down sends nothing either

  const std::string log = function_code_log(server);
  std::ofstream(stack.path("function-codes.log")) << log;
  INFO("function codes received from hvac-twind:\n" << log);
  CHECK(server.total_requests() == server.request_count(0x03) + server.request_count(0x04));
  for (const int write_code : {0x05, 0x06, 0x0F, 0x10, 0x16, 0x17}) {
    INFO("function code " << write_code);
    CHECK(server.request_count(static_cast<std::uint8_t>(write_code)) == 0);
  }

  // The counters see a write: a plain libmodbus master writes one register and a block.
  modbus_t* master = modbus_new_tcp("127.0.0.1", port);
  REQUIRE(master != nullptr);
  modbus_set_slave(master, 1);
  REQUIRE(modbus_connect(master) == 0);
  const std::uint16_t block[2] = {1, 2};
  CHECK(modbus_write_register(master, 10, 7) == 1);
  CHECK(modbus_write_registers(master, 11, 2, block) == 2);
  modbus_close(master);
  modbus_free(master);
  CHECK(server.request_count(0x06) == 1);
  CHECK(server.request_count(0x10) == 1);
  CHECK(server.total_requests() > server.request_count(0x03) + server.request_count(0x04));
}
