// A thin libmodbus (3.1.6) Modbus TCP client for one device: one connection, one request in
// flight. Not thread-safe: one thread (the device's poller thread) owns an instance.
//
// Read-only: the only requests it can build are 0x03 (read holding registers) and 0x04 (read
// input registers). There is no write path.
//
// Reply checking. libmodbus's TCP client does not check the unit id of a reply
// (modbus_read_registers() accepts a reply from another unit), and modbus_send_raw_request()
// always sends transaction id 0, so neither detects a duplicated or foreign reply. read()
// therefore frames the 12-byte request itself with an incrementing transaction id, writes it to
// the libmodbus socket, lets modbus_receive_confirmation() receive the reply under the response
// and byte timeouts, and validates the whole MBAP header and PDU with check_reply(): transaction
// id, protocol id 0, length field, unit id, function code, byte count. Any mismatch is a
// transport error (the stream is out of sync): the caller closes and reconnects.
#pragma once

#include <cstdint>
#include <span>
#include <string>

#include "config/config.hpp"

struct _modbus;  // libmodbus context (modbus_t), kept out of this header

namespace hvac_twin::modbus {

// libmodbus's MODBUS_ENOBASE: exception code c is reported as error number kModbusErrnoBase + c.
inline constexpr int kModbusErrnoBase = 112345678;

// Error numbers for replies that arrived but are not ours, above errno and libmodbus's EMB*
// range. error_text() names them.
inline constexpr int kErrBase = kModbusErrnoBase + 1000;
inline constexpr int kErrShortReply = kErrBase + 1;     // fewer than 9 bytes
inline constexpr int kErrTransactionId = kErrBase + 2;  // not the id we sent (late/duplicate)
inline constexpr int kErrProtocolId = kErrBase + 3;     // MBAP protocol id not 0
inline constexpr int kErrLengthField = kErrBase + 4;    // MBAP length disagrees with the ADU
inline constexpr int kErrUnitId = kErrBase + 5;         // reply from another unit id
inline constexpr int kErrFunction = kErrBase + 6;       // function code not the one we sent
inline constexpr int kErrByteCount = kErrBase + 7;      // byte count not 2 * registers asked
inline constexpr int kErrBadException = kErrBase + 8;   // exception reply malformed or code 0

enum class ReadOutcome : std::uint8_t {
  kOk,              // out[0, count) holds the registers
  kException,       // the device answered with exception_code; the connection is fine
  kTransportError,  // error_number says why; the connection must be closed and reopened
};

struct ReadResult {
  ReadOutcome outcome = ReadOutcome::kTransportError;
  std::uint8_t exception_code = 0;  // kException: 1..255 (0x01-0x04, 0x06 busy, 0x0A/0x0B ...)
  int error_number = 0;             // kTransportError: errno, libmodbus EMB* or kErr* above
};

// Validates one complete reply ADU (MBAP header + PDU) to a read request and copies the
// registers into out[0, count). Pure, no allocation; used by Client::read() and by tests/fuzzers.
ReadResult check_reply(std::span<const std::uint8_t> adu, std::uint16_t transaction_id,
                       std::uint8_t unit_id, std::uint8_t function_code, std::uint16_t count,
                       std::span<std::uint16_t> out) noexcept;

// Text for an error number from Client: kErr*, libmodbus EMB* or errno. Static storage.
const char* error_text(int error_number) noexcept;

class Client {
 public:
  // Start-up only (allocates, may block on name resolution). Resolves device.host once to an
  // IPv4 address (a later DNS change needs a restart), creates the libmodbus context and sets the
  // response and byte timeouts. Throws std::invalid_argument for a bad host, unit id or timeout,
  // std::runtime_error if libmodbus refuses.
  explicit Client(const config::ModbusDeviceConfig& device);
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  // Opens the connection (closing a previous one). Blocks at most response_timeout_s (libmodbus
  // bounds connect() by the response timeout). Returns 0, or the errno: ECONNREFUSED, or
  // EINPROGRESS for a connect that timed out (what libmodbus 3.1.6 leaves in errno; checked
  // against a black-holed loopback port), ... No allocation.
  int connect() noexcept;
  void close() noexcept;  // modbus_close(); idempotent
  bool is_connected() const noexcept;

  // One read request: 0x03 for kHolding, 0x04 for kInput. count 1..125, address + count <= 65536,
  // out.size() >= count (else kTransportError with EINVAL, nothing sent). Blocks at most
  // response_timeout_s + (reply bytes) * byte_timeout_s. No allocation, no exception.
  ReadResult read(config::RegisterKind kind, std::uint16_t address, std::uint16_t count,
                  std::span<std::uint16_t> out) noexcept;

  const std::string& ip_address() const noexcept { return ip_; }  // resolved, dotted quad
  std::uint16_t port() const noexcept { return port_; }

 private:
  ::_modbus* ctx_ = nullptr;
  std::string ip_;
  std::uint16_t port_ = 0;
  std::uint8_t unit_id_ = 0;
  std::uint16_t transaction_id_ = 0;
};

}  // namespace hvac_twin::modbus
