// A Modbus TCP fault-injection server on 127.0.0.1 for tests: raw sockets, every byte under the
// test's control. It answers read requests (0x03 holding, 0x04 input) correctly from a "good"
// register bank until a fault is injected; then it breaks the connection or the reply in one of
// the ways field devices and gateways do (FaultKind). Every broken reply that carries register
// data takes it from a second, "poison" bank, so a test that fills the poison bank with values it
// never serves correctly can prove that no broken reply was ever accepted as data.
//
// It can also black-hole connects: the listening socket (backlog 0) stops accepting and its
// accept queue is filled, so the kernel drops further SYNs and a client's connect() neither
// succeeds nor is refused (it times out). Existing connections get no replies meanwhile.
//
// Threads: construct, start(), stop() and destroy from one owner thread; inject(), the register
// setters, set_black_hole() and the counters from any thread. One server thread runs a poll()
// loop; nothing it does blocks (late replies are scheduled, not slept). Allocates; start-up
// failures throw std::system_error. Never binds anything but 127.0.0.1.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <mutex>
#include <span>
#include <string_view>
#include <thread>
#include <vector>

#include "config/config.hpp"
#include "io/modbus/decode.hpp"
#include "tests/fault/fault_frames.hpp"

namespace hvac_twin::test_fault {

enum class FaultKind : std::uint8_t {
  // Applied to the next read request received:
  kResetOnRequest,      // no reply; the connection is reset (RST, SO_LINGER 0)
  kFinOnRequest,        // no reply; the connection is closed in order (FIN)
  kGarbage,             // 1..64 random bytes instead of a reply; the connection stays open
  kWrongTransactionId,  // well-formed reply, transaction id + 1, poison data
  kWrongUnitId,         // well-formed reply from unit id + 1, poison data
  kWrongFunction,       // well-formed reply with the other read function code, poison data
  kBadProtocolId,       // well-formed reply with protocol id 1, poison data
  kShortFrame,          // MBAP header promising the whole reply, then only part of it: silence
  kShortPdu,            // complete, consistent frame with one register fewer, poison data
  kDuplicateReply,      // the correct reply, then a copy with poison data (desyncs the next read)
  kLateReply,           // the reply, with poison data, sent after late_reply_delay
  kNoReply,             // the request is swallowed (a hung device)
  kException,           // exception reply with Fault::exception_code
  // Applied at once, between requests, to every open connection:
  kResetIdle,  // RST
  kFinIdle,    // FIN
};
inline constexpr std::size_t kFaultKinds = 15;
std::string_view to_string(FaultKind kind) noexcept;

struct Fault {
  FaultKind kind = FaultKind::kNoReply;
  std::uint8_t exception_code = 0;  // kException: 0x01..0xFF
};

struct FaultServerOptions {
  std::uint16_t port = 0;  // 0 = ephemeral, chosen at the first start(); later starts reuse it
  int unit_id = 1;
  std::chrono::milliseconds late_reply_delay{500};  // kLateReply; above the client's timeout
  std::uint64_t seed = 1;                           // garbage bytes and lengths
};

class FaultServer {
 public:
  explicit FaultServer(FaultServerOptions options = {});
  ~FaultServer();  // stop()s
  FaultServer(const FaultServer&) = delete;
  FaultServer& operator=(const FaultServer&) = delete;

  // Binds 127.0.0.1:port with backlog 0 (SO_REUSEADDR) and starts the thread.
  void start();
  // Closes every socket and joins the thread (~50 ms). Registers and counters survive.
  void stop();
  std::uint16_t port() const noexcept { return port_.load(); }

  // Register banks: `good` serves correct replies, `poison` every broken reply with data.
  // Throws std::out_of_range past address 65535.
  void set_registers(config::RegisterKind kind, std::uint16_t address,
                     std::span<const std::uint16_t> values, bool poison = false);
  // modbus::encode(value) stored at the point's address (kOk or kSaturated; else nothing).
  modbus::EncodeStatus set_value(const config::PointConfig& point, double value,
                                 bool poison = false);

  // Queues a fault (FIFO) for the next read request; kResetIdle/kFinIdle act at once.
  void inject(const Fault& fault);
  std::size_t pending_faults() const;

  // true: stop accepting, fill the accept queue, answer nothing. false: accept again.
  // Returns once the server thread has switched (at most ~200 ms).
  void set_black_hole(bool on);

  // Counters since construction.
  std::uint64_t applied(FaultKind kind) const noexcept;  // faults that took effect
  std::uint64_t applied_total() const noexcept;
  std::uint64_t good_replies() const noexcept { return good_replies_.load(); }
  std::uint64_t requests(std::uint8_t function_code) const noexcept;
  std::uint64_t accepted_connections() const noexcept { return accepted_.load(); }
  std::uint64_t black_holed_requests() const noexcept { return black_holed_.load(); }
  std::size_t client_count() const noexcept { return clients_now_.load(); }

 private:
  struct Client {
    int fd = -1;
    std::uint64_t id = 0;
    Bytes in;                     // received, not yet a complete request
    std::uint8_t close_mode = 0;  // how close_client() ends it: 0 close, 1 FIN first, 2 RST
  };
  struct Delayed {
    std::uint64_t client_id = 0;
    std::chrono::steady_clock::time_point due;
    Bytes bytes;
  };

  void run() noexcept;
  void accept_all() noexcept;
  bool read_client(Client& c) noexcept;  // false: close it
  bool handle(Client& c, std::span<const std::uint8_t> adu) noexcept;
  bool apply(Client& c, const Request& r, const Fault& f) noexcept;
  void apply_idle(bool reset) noexcept;
  void send_due() noexcept;
  void enter_black_hole() noexcept;
  void leave_black_hole() noexcept;
  std::vector<std::uint16_t> bank(const Request& r, bool poison, std::size_t count) const;
  Bytes garbage();
  void close_client(std::size_t index) noexcept;
  void wake() noexcept;

  FaultServerOptions options_;
  mutable std::mutex mutex_;                        // guards the banks and the queue
  std::vector<std::uint16_t> good_[2], poison_[2];  // [0] holding, [1] input; 65536 each
  std::deque<Fault> queue_;
  std::atomic<int> idle_resets_{0}, idle_fins_{0};
  std::atomic<bool> want_black_hole_{false};
  std::atomic<bool> black_hole_{false};  // what the server thread has switched to

  int listen_fd_ = -1;
  int wake_pipe_[2] = {-1, -1};
  std::vector<Client> clients_;  // server thread only
  std::vector<int> fillers_;     // server thread only: connections filling the accept queue
  std::vector<Delayed> delayed_;
  std::uint64_t next_client_id_ = 1;
  std::uint64_t rng_ = 0;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint16_t> port_{0};
  std::array<std::atomic<std::uint64_t>, kFaultKinds> applied_{};
  std::array<std::atomic<std::uint64_t>, 256> functions_{};
  std::atomic<std::uint64_t> good_replies_{0};
  std::atomic<std::uint64_t> accepted_{0};
  std::atomic<std::uint64_t> black_holed_{0};
  std::atomic<std::size_t> clients_now_{0};
};

}  // namespace hvac_twin::test_fault
