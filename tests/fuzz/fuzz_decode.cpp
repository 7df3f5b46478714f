// libFuzzer target: register decoding and encoding (io/modbus/decode.hpp) for any point
// configuration. Input layout (little-endian, zero-filled past the end):
//   u8 type, u8 word order, f64 scale, f64 offset, f64 range_min, f64 range_max,
//   u16 r0, u16 r1 (big-endian, as on the wire), f64 engineering value for encode
// Invariants: decode kOk => finite value inside [range_min, range_max]; kOutOfRange => finite
// value outside it; with scale 1 and offset 0 a decoded value encodes back to the same
// registers; encode never writes a register for a refused input.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <span>

#include "io/modbus/decode.hpp"
#include "tests/fuzz/fuzz_input.hpp"

using hvac_twin::config::PointConfig;
using hvac_twin::config::ValueType;
using hvac_twin::config::WordOrder;
namespace mb = hvac_twin::modbus;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  hvac_twin::fuzz::InputReader in(data, size);
  PointConfig p;
  p.type = static_cast<ValueType>(in.take<std::uint8_t>() % 5);
  p.word_order = static_cast<WordOrder>(in.take<std::uint8_t>() % 4);
  p.scale = in.take<double>();
  p.offset = in.take<double>();
  p.range_min = in.take<double>();
  p.range_max = in.take<double>();
  const std::uint16_t regs[2] = {in.take_be16(), in.take_be16()};
  const double engineering = in.take<double>();
  const auto n = static_cast<std::size_t>(mb::registers_for(p.type));
  HVAC_TWIN_FUZZ_CHECK(n == 1 || n == 2);

  // Wrong register counts are refused, never read past.
  for (std::size_t count = 0; count <= 2; ++count) {
    const auto d = mb::decode(std::span(regs, count), p);
    if (count != n) HVAC_TWIN_FUZZ_CHECK(d.status == mb::DecodeStatus::kWrongRegisterCount);
  }
  const auto d = mb::decode(std::span(regs, n), p);
  const bool valid_order = mb::is_valid_word_order(p.type, p.word_order);
  HVAC_TWIN_FUZZ_CHECK(valid_order || d.status == mb::DecodeStatus::kInvalidWordOrder);
  if (d.status == mb::DecodeStatus::kOk) {
    HVAC_TWIN_FUZZ_CHECK(std::isfinite(d.value));
    HVAC_TWIN_FUZZ_CHECK(d.value >= p.range_min && d.value <= p.range_max);
  }
  if (d.status == mb::DecodeStatus::kOutOfRange) {
    HVAC_TWIN_FUZZ_CHECK(std::isfinite(d.value));
    HVAC_TWIN_FUZZ_CHECK(!(d.value >= p.range_min && d.value <= p.range_max));
  }

  // Round trip of the raw value: with scale 1 and offset 0 encode(decode(r)) == r.
  PointConfig identity = p;
  identity.scale = 1.0;
  identity.offset = 0.0;
  const double raw = mb::decode_raw(std::span(regs, n), p.type, p.word_order);
  if (valid_order && std::isfinite(raw)) {
    std::uint16_t back[2] = {0xDEAD, 0xBEEF};
    const auto s = mb::encode(raw, identity, std::span(back, n));
    HVAC_TWIN_FUZZ_CHECK(s == mb::EncodeStatus::kOk);
    HVAC_TWIN_FUZZ_CHECK(back[0] == regs[0] && (n == 1 || back[1] == regs[1]));
  }

  // encode of any value with any configuration: defined behaviour, untouched output on refusal.
  std::uint16_t out[2] = {0x1234, 0x5678};
  const auto e = mb::encode(engineering, p, std::span(out, n));
  if (e != mb::EncodeStatus::kOk && e != mb::EncodeStatus::kSaturated)
    HVAC_TWIN_FUZZ_CHECK(out[0] == 0x1234 && out[1] == 0x5678);
  if (e == mb::EncodeStatus::kOk || e == mb::EncodeStatus::kSaturated)
    (void)mb::decode(std::span<const std::uint16_t>(out, n), p);
  return 0;
}
