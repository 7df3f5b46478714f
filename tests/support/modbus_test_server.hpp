// A real libmodbus Modbus TCP server on 127.0.0.1 for unit tests, integration tests and the
// plant simulator. Serves holding and input registers from a modbus_mapping_t (addresses
// 0..n-1; a read beyond answers exception 0x02), to several clients at once, from one thread
// running a poll() loop. Never binds anything but 127.0.0.1.
//
// Threads: construct, start(), stop() and destroy from one owner thread; the setters, getters,
// fault injection and counters may be called from any thread at any time. Allocates; start-up
// failures throw std::system_error. Not for production: it also answers write requests (counted
// per function code, so a test can prove a client never sent one).
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <span>
#include <thread>
#include <vector>

#include "config/config.hpp"
#include "io/modbus/decode.hpp"

struct _modbus;
struct _modbus_mapping_t;

namespace hvac_twin::test_support {

// What the server does with a request addressed to another unit id than its own.
enum class UnitIdPolicy : std::uint8_t {
  kGatewayException,  // answer exception 0x0B "gateway target failed to respond" (default)
  kIgnore,            // no reply at all: the client times out
  kAnswerAny,         // serve it anyway, echoing the request's unit id (many TCP devices do)
};

struct ModbusTestServerOptions {
  std::uint16_t port = 0;  // 0 = ephemeral, chosen at the first start(); later starts reuse it
  int unit_id = 1;         // 0..255
  UnitIdPolicy unit_id_policy = UnitIdPolicy::kGatewayException;
  int holding_registers = 65536;  // served addresses 0..n-1 (default: all of them)
  int input_registers = 65536;
  int max_clients = 16;  // further connections are accepted and closed at once
};

// Fault injection for tests; applied to every request received after set_faults() returns.
struct ServerFaults {
  int reply_unit_id = -1;             // 0..255: reply with this unit id instead of the request's
  int transaction_id_delta = 0;       // added to the echoed transaction id (a desynced reply)
  std::uint8_t forced_exception = 0;  // 0x01..0x0B: answer requests with this exception
  int forced_exception_budget = -1;   // -1: every request; n >= 0: only the next n requests
  bool drop_requests = false;         // read requests but never answer (a hung device)
};

class ModbusTestServer {
 public:
  explicit ModbusTestServer(ModbusTestServerOptions options = {});
  ~ModbusTestServer();  // stop()s
  ModbusTestServer(const ModbusTestServer&) = delete;
  ModbusTestServer& operator=(const ModbusTestServer&) = delete;

  // Binds 127.0.0.1:port (SO_REUSEADDR, so a restart on the same port works at once) and starts
  // the thread. Throws std::system_error (e.g. EADDRINUSE) or std::logic_error if running.
  void start();
  // Closes the listening socket and every client connection and joins the thread; returns
  // within ~100 ms plus any reply being sent. Register values and counters survive a restart.
  void stop();
  bool running() const noexcept { return running_.load(); }
  std::uint16_t port() const noexcept { return port_.load(); }  // 0 before the first start()

  // Thread-safe register access. Throws std::out_of_range outside the served addresses.
  void set_registers(config::RegisterKind kind, std::uint16_t address,
                     std::span<const std::uint16_t> values);
  void get_registers(config::RegisterKind kind, std::uint16_t address,
                     std::span<std::uint16_t> out) const;
  // Encodes an engineering value for `point` (modbus::encode) and stores it. A non-ok status
  // other than kSaturated stores nothing.
  modbus::EncodeStatus set_value(const config::PointConfig& point, double engineering_value);

  void set_faults(const ServerFaults& faults);
  ServerFaults faults() const;

  // Drops every client connection (the listening socket stays): a connection reset for clients.
  void disconnect_clients();

  std::uint64_t request_count(std::uint8_t function_code) const noexcept;
  std::uint64_t total_requests() const noexcept;
  std::uint64_t accepted_connections() const noexcept { return accepted_.load(); }
  std::size_t client_count() const noexcept { return clients_now_.load(); }

 private:
  void run() noexcept;
  bool serve_one(int fd) noexcept;  // false: close this client
  void close_clients() noexcept;
  void wake() noexcept;

  ModbusTestServerOptions options_;
  ::_modbus_mapping_t* mapping_ = nullptr;
  mutable std::mutex mutex_;  // guards mapping_ contents and faults_
  ServerFaults faults_;

  ::_modbus* ctx_ = nullptr;  // server thread only while running
  int listen_fd_ = -1;
  int wake_pipe_[2] = {-1, -1};
  std::vector<int> clients_;  // server thread only
  std::thread thread_;
  std::atomic<bool> running_{false};
  std::atomic<bool> stop_{false};
  std::atomic<bool> drop_clients_{false};
  std::atomic<std::uint16_t> port_{0};
  std::atomic<std::uint64_t> accepted_{0};
  std::atomic<std::size_t> clients_now_{0};
  std::array<std::atomic<std::uint64_t>, 256> function_counts_{};
};

}  // namespace hvac_twin::test_support
