// libFuzzer target: the Modbus TCP reply checker (modbus::check_reply in io/modbus/client).
// Input: u16 transaction id (big-endian), u8 unit id, u8 function selector (bit 0: 0x03 or
// 0x04), u8 register count (1..125 as 1 + byte % 125), then the reply ADU (any bytes).
// Invariants: kOk only for a reply of exactly 9 + 2 * count bytes whose header matches the
// request, with the registers copied big-endian and nothing written past count; kException only
// for a 9-byte reply with function | 0x80 and a non-zero code; a transport error names a reason.
#include <array>
#include <cstddef>
#include <cstdint>
#include <span>

#include "io/modbus/client.hpp"
#include "tests/fuzz/fuzz_input.hpp"

namespace mb = hvac_twin::modbus;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  hvac_twin::fuzz::InputReader in(data, size);
  const std::uint16_t tid = in.take_be16();
  const auto unit = in.take<std::uint8_t>();
  const std::uint8_t function = (in.take<std::uint8_t>() & 1) != 0 ? 0x04 : 0x03;
  const auto count = static_cast<std::uint16_t>(1 + in.take<std::uint8_t>() % 125);
  const auto adu = in.rest();

  std::array<std::uint16_t, 126> out{};
  out.fill(0xA5A5);
  const auto r = mb::check_reply(adu, tid, unit, function, count, std::span(out.data(), count));
  const auto be16 = [&](std::size_t i) {
    return static_cast<std::uint16_t>((adu[i] << 8) | adu[i + 1]);
  };
  switch (r.outcome) {
    case mb::ReadOutcome::kOk:
      HVAC_TWIN_FUZZ_CHECK(adu.size() == 9u + 2u * count);
      HVAC_TWIN_FUZZ_CHECK(be16(0) == tid && be16(2) == 0 && be16(4) == adu.size() - 6);
      HVAC_TWIN_FUZZ_CHECK(adu[6] == unit && adu[7] == function && adu[8] == 2 * count);
      for (std::size_t i = 0; i < count; ++i)
        HVAC_TWIN_FUZZ_CHECK(out[i] == be16(9 + 2 * i));
      break;
    case mb::ReadOutcome::kException:
      HVAC_TWIN_FUZZ_CHECK(adu.size() == 9 && adu[7] == (function | 0x80));
      HVAC_TWIN_FUZZ_CHECK(r.exception_code != 0 && r.exception_code == adu[8]);
      HVAC_TWIN_FUZZ_CHECK(be16(0) == tid && adu[6] == unit);
      break;
    case mb::ReadOutcome::kTransportError:
      HVAC_TWIN_FUZZ_CHECK(r.error_number > mb::kErrBase && r.error_number <= mb::kErrBase + 8);
      HVAC_TWIN_FUZZ_CHECK(mb::error_text(r.error_number) != nullptr);
      break;
  }
  if (r.outcome != mb::ReadOutcome::kOk) {
    for (std::size_t i = 0; i < out.size(); ++i)
      HVAC_TWIN_FUZZ_CHECK(out[i] == 0xA5A5);  // nothing copied from a refused reply
  }
  HVAC_TWIN_FUZZ_CHECK(out[count] == 0xA5A5);  // nothing written past count
  return 0;
}
