// Register decoding and encoding: pure functions, no I/O, no allocation, no exceptions; any
// thread. Fuzzable: every input span and config value is handled without UB.
//
// Register layout (see config::WordOrder): bytes A B C D, A most significant. Register i holds
// two bytes sent big-endian, so for 32-bit values
//   ABCD: r0 = AB, r1 = CD      CDAB: r0 = CD, r1 = AB
//   BADC: r0 = BA, r1 = DC      DCBA: r0 = DC, r1 = BA
// and for 16-bit values ABCD: r0 = AB, BADC: r0 = BA (CDAB and DCBA are invalid there).
#pragma once

#include <cstdint>
#include <span>
#include <string_view>

#include "config/config.hpp"

namespace hvac_twin::modbus {

// Number of 16-bit registers a value type occupies: 1 (int16, uint16) or 2 (32-bit types).
int registers_for(config::ValueType type) noexcept;

// False for the combinations that have no meaning (CDAB or DCBA on a 16-bit type).
bool is_valid_word_order(config::ValueType type, config::WordOrder order) noexcept;

enum class DecodeStatus : std::uint8_t {
  kOk,                  // value is finite and inside [range_min, range_max]
  kWrongRegisterCount,  // regs.size() != registers_for(type)
  kInvalidWordOrder,    // see is_valid_word_order()
  kNotFinite,           // float32 NaN/Inf, or raw * scale + offset not finite
  kOutOfRange,          // finite, but outside [range_min, range_max]; value is still set
};

struct DecodeResult {
  double value = 0.0;  // engineering value [point unit]; meaningful for kOk and kOutOfRange
  DecodeStatus status = DecodeStatus::kOk;
};

std::string_view to_string(DecodeStatus s) noexcept;

// The raw register value as a number, before scale and offset: the integer, or the float32
// widened to double (may be NaN/Inf). Precondition-free: returns NaN for a wrong register count
// or an invalid word order.
double decode_raw(std::span<const std::uint16_t> regs, config::ValueType type,
                  config::WordOrder order) noexcept;

// Engineering value = raw * point.scale + point.offset, checked: finite, then inside
// [point.range_min, point.range_max] (inclusive). regs must hold exactly registers_for(type).
DecodeResult decode(std::span<const std::uint16_t> regs, const config::PointConfig& point) noexcept;

enum class EncodeStatus : std::uint8_t {
  kOk,                  // out holds the nearest representable raw value
  kSaturated,           // not representable: out holds the type's min or max (nearest end)
  kNotFinite,           // engineering_value NaN/Inf: out untouched
  kWrongRegisterCount,  // out.size() != registers_for(type): out untouched
  kInvalidWordOrder,    // out untouched
  kInvalidScale,        // scale zero or not finite, or offset not finite: out untouched
};

std::string_view to_string(EncodeStatus s) noexcept;

// Inverse of decode (used by simulators and tests to serve values): raw = (value - offset) /
// scale, rounded to the nearest integer (halves away from zero) for integer types, rounded to the
// nearest float for float32, saturated at the type's limits. Does NOT check the physical range:
// a simulator may serve out-of-range values on purpose.
EncodeStatus encode(double engineering_value, const config::PointConfig& point,
                    std::span<std::uint16_t> out) noexcept;

}  // namespace hvac_twin::modbus
