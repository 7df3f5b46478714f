#include "io/modbus/client.hpp"

#include <arpa/inet.h>
#include <modbus/modbus.h>
#include <netdb.h>
#include <sys/socket.h>

#include <cerrno>
#include <cmath>
#include <stdexcept>

#include "io/modbus/plan.hpp"

static_assert(MODBUS_ENOBASE == hvac_twin::modbus::kModbusErrnoBase, "libmodbus error base");

namespace hvac_twin::modbus {
namespace {

constexpr std::size_t kMbapLength = 7;  // transaction id, protocol id, length, unit id

std::string resolve_ipv4(const std::string& host) {
  in_addr numeric{};
  if (inet_pton(AF_INET, host.c_str(), &numeric) == 1) return host;
  addrinfo hints{};
  hints.ai_family = AF_INET;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  const int rc = getaddrinfo(host.c_str(), nullptr, &hints, &found);
  if (rc != 0 || found == nullptr) {
    throw std::invalid_argument("modbus: cannot resolve host \"" + host +
                                "\" to an IPv4 address: " + gai_strerror(rc));
  }
  char text[INET_ADDRSTRLEN] = {};
  const auto* sin = reinterpret_cast<const sockaddr_in*>(found->ai_addr);
  inet_ntop(AF_INET, &sin->sin_addr, text, sizeof text);
  freeaddrinfo(found);
  return text;
}

void set_timeout(modbus_t* ctx, double seconds, const char* what,
                 int (*setter)(modbus_t*, std::uint32_t, std::uint32_t)) {
  if (!std::isfinite(seconds) || seconds <= 0.0 || seconds > 3600.0) {
    throw std::invalid_argument(std::string("modbus: ") + what + " must be in (0, 3600] s");
  }
  const auto usec_total = static_cast<std::uint64_t>(std::llround(seconds * 1e6));
  const auto sec = static_cast<std::uint32_t>(usec_total / 1000000u);
  auto usec = static_cast<std::uint32_t>(usec_total % 1000000u);
  if (sec == 0 && usec == 0) usec = 1;
  if (setter(ctx, sec, usec) != 0) {
    throw std::invalid_argument(std::string("modbus: libmodbus refused the ") + what);
  }
}

ReadResult transport(int error_number) noexcept {
  return {ReadOutcome::kTransportError, 0, error_number};
}

}  // namespace

ReadResult check_reply(std::span<const std::uint8_t> adu, std::uint16_t transaction_id,
                       std::uint8_t unit_id, std::uint8_t function_code, std::uint16_t count,
                       std::span<std::uint16_t> out) noexcept {
  if (adu.size() < kMbapLength + 2) return transport(kErrShortReply);
  const auto be16 = [&](std::size_t i) {
    return static_cast<std::uint16_t>((adu[i] << 8) | adu[i + 1]);
  };
  if (be16(0) != transaction_id) return transport(kErrTransactionId);
  if (be16(2) != 0) return transport(kErrProtocolId);
  if (be16(4) != adu.size() - 6) return transport(kErrLengthField);
  if (adu[6] != unit_id) return transport(kErrUnitId);
  const std::uint8_t function = adu[7];
  if (function == (function_code | 0x80u)) {
    if (adu.size() != kMbapLength + 2 || adu[8] == 0) return transport(kErrBadException);
    return {ReadOutcome::kException, adu[8], 0};
  }
  if (function != function_code) return transport(kErrFunction);
  const std::size_t bytes = 2u * count;
  if (adu[8] != bytes || adu.size() != kMbapLength + 2 + bytes || out.size() < count) {
    return transport(kErrByteCount);
  }
  for (std::size_t i = 0; i < count; ++i)
    out[i] = be16(kMbapLength + 2 + 2 * i);
  return {ReadOutcome::kOk, 0, 0};
}

const char* error_text(int error_number) noexcept {
  switch (error_number) {
    case kErrShortReply:
      return "reply too short";
    case kErrTransactionId:
      return "reply transaction id mismatch (late or duplicate reply)";
    case kErrProtocolId:
      return "reply protocol id not 0";
    case kErrLengthField:
      return "reply MBAP length field mismatch";
    case kErrUnitId:
      return "reply unit id mismatch";
    case kErrFunction:
      return "reply function code mismatch";
    case kErrByteCount:
      return "reply byte count mismatch";
    case kErrBadException:
      return "malformed exception reply";
    default:
      return modbus_strerror(error_number);
  }
}

Client::Client(const config::ModbusDeviceConfig& device) {
  if (device.unit_id < 0 || device.unit_id > 255) {
    throw std::invalid_argument("modbus: unit_id must be in 0..255");
  }
  if (device.port == 0) throw std::invalid_argument("modbus: port must be in 1..65535");
  ip_ = resolve_ipv4(device.host);
  port_ = device.port;
  unit_id_ = static_cast<std::uint8_t>(device.unit_id);
  ctx_ = modbus_new_tcp(ip_.c_str(), port_);
  if (ctx_ == nullptr) {
    throw std::runtime_error(std::string("modbus: modbus_new_tcp failed: ") +
                             modbus_strerror(errno));
  }
  try {
    // Both timeouts must be non-zero: a zero byte timeout makes libmodbus wait forever for the
    // rest of a reply. Error recovery stays MODBUS_ERROR_RECOVERY_NONE (it would sleep).
    set_timeout(ctx_, device.response_timeout_s, "response timeout", &modbus_set_response_timeout);
    set_timeout(ctx_, device.byte_timeout_s, "byte timeout", &modbus_set_byte_timeout);
  } catch (...) {
    modbus_free(ctx_);
    throw;
  }
}

Client::~Client() {
  close();
  modbus_free(ctx_);
}

int Client::connect() noexcept {
  close();
  errno = 0;
  if (modbus_connect(ctx_) != 0) {
    const int e = errno != 0 ? errno : ECONNREFUSED;
    close();
    return e;
  }
  return 0;
}

void Client::close() noexcept {
  if (modbus_get_socket(ctx_) >= 0) modbus_close(ctx_);
  modbus_set_socket(ctx_, -1);
}

bool Client::is_connected() const noexcept {
  return modbus_get_socket(ctx_) >= 0;
}

ReadResult Client::read(config::RegisterKind kind, std::uint16_t address, std::uint16_t count,
                        std::span<std::uint16_t> out) noexcept {
  if (count == 0 || count > kMaxRegistersPerRead || out.size() < count ||
      std::uint32_t{address} + count > 65536u) {
    return transport(EINVAL);
  }
  const int fd = modbus_get_socket(ctx_);
  if (fd < 0) return transport(EBADF);

  const std::uint8_t function = kind == config::RegisterKind::kInput
                                    ? MODBUS_FC_READ_INPUT_REGISTERS
                                    : MODBUS_FC_READ_HOLDING_REGISTERS;
  const std::uint16_t tid = ++transaction_id_;
  const std::uint8_t request[12] = {static_cast<std::uint8_t>(tid >> 8),
                                    static_cast<std::uint8_t>(tid & 0xFF),
                                    0,
                                    0,  // protocol id
                                    0,
                                    6,  // length: unit id + 5-byte PDU
                                    unit_id_,
                                    function,
                                    static_cast<std::uint8_t>(address >> 8),
                                    static_cast<std::uint8_t>(address & 0xFF),
                                    static_cast<std::uint8_t>(count >> 8),
                                    static_cast<std::uint8_t>(count & 0xFF)};
  // libmodbus's socket is non-blocking; 12 bytes with no other request in flight always fit into
  // the send buffer, so a short write means a broken connection. MSG_NOSIGNAL: EPIPE, no SIGPIPE.
  const ssize_t sent = ::send(fd, request, sizeof request, MSG_NOSIGNAL);
  if (sent != static_cast<ssize_t>(sizeof request)) return transport(sent < 0 ? errno : EIO);

  std::uint8_t reply[MODBUS_TCP_MAX_ADU_LENGTH];
  errno = 0;
  const int length = modbus_receive_confirmation(ctx_, reply);
  if (length < 0) return transport(errno != 0 ? errno : EMBBADDATA);
  return check_reply(std::span<const std::uint8_t>(reply, static_cast<std::size_t>(length)), tid,
                     unit_id_, function, count, out);
}

}  // namespace hvac_twin::modbus
