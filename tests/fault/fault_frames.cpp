#include "tests/fault/fault_frames.hpp"

namespace hvac_twin::test_fault {
namespace {

std::uint16_t be16(std::span<const std::uint8_t> b, std::size_t i) {
  return static_cast<std::uint16_t>((b[i] << 8) | b[i + 1]);
}

Bytes header(const Request& request, std::size_t pdu_length) {
  Bytes adu(kMbapLength, 0);
  put16(adu, 0, request.transaction_id);
  put16(adu, 2, 0);
  put16(adu, 4, static_cast<std::uint16_t>(pdu_length + 1));  // unit id + PDU
  adu[6] = request.unit_id;
  return adu;
}

}  // namespace

void put16(Bytes& adu, std::size_t offset, std::uint16_t value) {
  adu.at(offset) = static_cast<std::uint8_t>(value >> 8);
  adu.at(offset + 1) = static_cast<std::uint8_t>(value & 0xFF);
}

std::optional<std::size_t> frame_length(std::span<const std::uint8_t> stream, bool* invalid) {
  *invalid = false;
  if (stream.size() < kMbapLength) return std::nullopt;
  const std::size_t length = be16(stream, 4);
  if (length == 0 || 6 + length > kMaxAduLength) {
    *invalid = true;
    return std::nullopt;
  }
  return 6 + length;
}

std::optional<Request> parse_request(std::span<const std::uint8_t> adu) {
  if (adu.size() < kMbapLength + 1) return std::nullopt;
  Request r;
  r.transaction_id = be16(adu, 0);
  r.protocol_id = be16(adu, 2);
  r.unit_id = adu[6];
  r.function = adu[7];
  if (r.is_read()) {
    if (adu.size() < kMbapLength + 5) return std::nullopt;
    r.address = be16(adu, 8);
    r.count = be16(adu, 10);
  }
  return r;
}

Bytes read_reply(const Request& request, std::span<const std::uint16_t> registers) {
  const std::size_t bytes = 2 * registers.size();
  Bytes adu = header(request, 2 + bytes);
  adu.push_back(request.function);
  adu.push_back(static_cast<std::uint8_t>(bytes & 0xFF));
  for (const std::uint16_t r : registers) {
    adu.push_back(static_cast<std::uint8_t>(r >> 8));
    adu.push_back(static_cast<std::uint8_t>(r & 0xFF));
  }
  return adu;
}

Bytes exception_reply(const Request& request, std::uint8_t code) {
  Bytes adu = header(request, 2);
  adu.push_back(static_cast<std::uint8_t>(request.function | 0x80));
  adu.push_back(code);
  return adu;
}

}  // namespace hvac_twin::test_fault
