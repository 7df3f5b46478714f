// Modbus TCP frames for the fault-injection server: parsing a request ADU and building the
// correct and the deliberately broken replies. Pure functions; they allocate (test code only).
//
// A reply ADU is MBAP (transaction id, protocol id 0, length = bytes after the length field,
// unit id) followed by the PDU (function code, then byte count and registers, or the exception
// code). Every builder returns the complete ADU as bytes ready for send().
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace hvac_twin::test_fault {

inline constexpr std::size_t kMbapLength = 7;  // transaction id, protocol id, length, unit id
inline constexpr std::size_t kMaxAduLength = 260;

using Bytes = std::vector<std::uint8_t>;

// A request as received. `function` is any code; address and count are meaningful for 0x03/0x04.
struct Request {
  std::uint16_t transaction_id = 0;
  std::uint16_t protocol_id = 0;
  std::uint8_t unit_id = 0;
  std::uint8_t function = 0;
  std::uint16_t address = 0;
  std::uint16_t count = 0;
  bool is_read() const { return function == 0x03 || function == 0x04; }
};

// Length of the complete ADU that starts `stream`, once its MBAP header has arrived (6 + the
// length field); nullopt while fewer than 7 bytes are there or when the length field is 0 or
// larger than a Modbus TCP ADU allows (the stream cannot be re-synchronised: close it).
std::optional<std::size_t> frame_length(std::span<const std::uint8_t> stream, bool* invalid);

// Parses one complete request ADU (frame_length() bytes). nullopt if shorter than MBAP + function,
// or a read request without its 4 bytes of address and count.
std::optional<Request> parse_request(std::span<const std::uint8_t> adu);

// A well-formed read reply: the request's transaction id, protocol 0, its unit and function,
// byte count 2 * registers.size() and the registers big-endian.
Bytes read_reply(const Request& request, std::span<const std::uint16_t> registers);

// An exception reply: function | 0x80, then `code`.
Bytes exception_reply(const Request& request, std::uint8_t code);

// Overwrites the big-endian 16-bit field at byte `offset` of `adu`.
void put16(Bytes& adu, std::size_t offset, std::uint16_t value);

}  // namespace hvac_twin::test_fault
