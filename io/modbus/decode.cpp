#include "io/modbus/decode.hpp"

#include <bit>
#include <cmath>
#include <limits>

namespace hvac_twin::modbus {
namespace {

using config::ValueType;
using config::WordOrder;

constexpr std::uint16_t swap_bytes(std::uint16_t r) noexcept {
  return static_cast<std::uint16_t>((r << 8) | (r >> 8));
}

// Bytes A B C D of a 32-bit value from two registers in the given order.
constexpr std::uint32_t assemble32(std::uint16_t r0, std::uint16_t r1, WordOrder order) noexcept {
  std::uint16_t hi = r0;  // AB
  std::uint16_t lo = r1;  // CD
  switch (order) {
    case WordOrder::kABCD:
      break;
    case WordOrder::kCDAB:
      hi = r1;
      lo = r0;
      break;
    case WordOrder::kBADC:
      hi = swap_bytes(r0);
      lo = swap_bytes(r1);
      break;
    case WordOrder::kDCBA:
      hi = swap_bytes(r1);
      lo = swap_bytes(r0);
      break;
  }
  return (std::uint32_t{hi} << 16) | lo;
}

constexpr void disassemble32(std::uint32_t v, WordOrder order, std::span<std::uint16_t> out) {
  const auto hi = static_cast<std::uint16_t>(v >> 16);
  const auto lo = static_cast<std::uint16_t>(v & 0xFFFFu);
  switch (order) {
    case WordOrder::kABCD:
      out[0] = hi;
      out[1] = lo;
      break;
    case WordOrder::kCDAB:
      out[0] = lo;
      out[1] = hi;
      break;
    case WordOrder::kBADC:
      out[0] = swap_bytes(hi);
      out[1] = swap_bytes(lo);
      break;
    case WordOrder::kDCBA:
      out[0] = swap_bytes(lo);
      out[1] = swap_bytes(hi);
      break;
  }
}

constexpr std::uint16_t assemble16(std::uint16_t r0, WordOrder order) noexcept {
  return order == WordOrder::kBADC ? swap_bytes(r0) : r0;
}

// Rounds and saturates `raw` into [lo, hi]; sets *saturated when clamped.
template <typename Int>
Int to_integer(double raw, bool* saturated) noexcept {
  constexpr double lo = static_cast<double>(std::numeric_limits<Int>::min());
  constexpr double hi = static_cast<double>(std::numeric_limits<Int>::max());
  const double r = std::round(raw);
  if (r < lo) {
    *saturated = true;
    return std::numeric_limits<Int>::min();
  }
  if (r > hi) {
    *saturated = true;
    return std::numeric_limits<Int>::max();
  }
  return static_cast<Int>(r);
}

}  // namespace

int registers_for(ValueType type) noexcept {
  switch (type) {
    case ValueType::kInt16:
    case ValueType::kUint16:
      return 1;
    case ValueType::kInt32:
    case ValueType::kUint32:
    case ValueType::kFloat32:
      return 2;
  }
  return 2;
}

bool is_valid_word_order(ValueType type, WordOrder order) noexcept {
  switch (order) {
    case WordOrder::kABCD:
    case WordOrder::kBADC:
      return true;
    case WordOrder::kCDAB:
    case WordOrder::kDCBA:
      return registers_for(type) == 2;
  }
  return false;
}

std::string_view to_string(DecodeStatus s) noexcept {
  switch (s) {
    case DecodeStatus::kOk:
      return "ok";
    case DecodeStatus::kWrongRegisterCount:
      return "wrong register count";
    case DecodeStatus::kInvalidWordOrder:
      return "invalid word order for type";
    case DecodeStatus::kNotFinite:
      return "value not finite";
    case DecodeStatus::kOutOfRange:
      return "value out of range";
  }
  return "unknown";
}

std::string_view to_string(EncodeStatus s) noexcept {
  switch (s) {
    case EncodeStatus::kOk:
      return "ok";
    case EncodeStatus::kSaturated:
      return "saturated";
    case EncodeStatus::kNotFinite:
      return "value not finite";
    case EncodeStatus::kWrongRegisterCount:
      return "wrong register count";
    case EncodeStatus::kInvalidWordOrder:
      return "invalid word order for type";
    case EncodeStatus::kInvalidScale:
      return "invalid scale or offset";
  }
  return "unknown";
}

double decode_raw(std::span<const std::uint16_t> regs, ValueType type, WordOrder order) noexcept {
  if (regs.size() != static_cast<std::size_t>(registers_for(type)) ||
      !is_valid_word_order(type, order)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  switch (type) {
    case ValueType::kInt16:
      return static_cast<double>(std::bit_cast<std::int16_t>(assemble16(regs[0], order)));
    case ValueType::kUint16:
      return static_cast<double>(assemble16(regs[0], order));
    case ValueType::kInt32:
      return static_cast<double>(std::bit_cast<std::int32_t>(assemble32(regs[0], regs[1], order)));
    case ValueType::kUint32:
      return static_cast<double>(assemble32(regs[0], regs[1], order));
    case ValueType::kFloat32:
      return static_cast<double>(std::bit_cast<float>(assemble32(regs[0], regs[1], order)));
  }
  return std::numeric_limits<double>::quiet_NaN();
}

DecodeResult decode(std::span<const std::uint16_t> regs,
                    const config::PointConfig& point) noexcept {
  if (regs.size() != static_cast<std::size_t>(registers_for(point.type))) {
    return {0.0, DecodeStatus::kWrongRegisterCount};
  }
  if (!is_valid_word_order(point.type, point.word_order)) {
    return {0.0, DecodeStatus::kInvalidWordOrder};
  }
  const double raw = decode_raw(regs, point.type, point.word_order);
  const double value = raw * point.scale + point.offset;
  if (!std::isfinite(raw) || !std::isfinite(value)) return {0.0, DecodeStatus::kNotFinite};
  // Written so that a NaN range bound also rejects the value.
  if (!(value >= point.range_min && value <= point.range_max)) {
    return {value, DecodeStatus::kOutOfRange};
  }
  return {value, DecodeStatus::kOk};
}

EncodeStatus encode(double engineering_value, const config::PointConfig& point,
                    std::span<std::uint16_t> out) noexcept {
  if (out.size() != static_cast<std::size_t>(registers_for(point.type))) {
    return EncodeStatus::kWrongRegisterCount;
  }
  if (!is_valid_word_order(point.type, point.word_order)) return EncodeStatus::kInvalidWordOrder;
  if (!std::isfinite(point.scale) || point.scale == 0.0 || !std::isfinite(point.offset)) {
    return EncodeStatus::kInvalidScale;
  }
  if (!std::isfinite(engineering_value)) return EncodeStatus::kNotFinite;

  const double raw = (engineering_value - point.offset) / point.scale;
  bool saturated = !std::isfinite(raw);  // finite / tiny scale can overflow to +-Inf
  const WordOrder order = point.word_order;
  switch (point.type) {
    case ValueType::kInt16:
      out[0] = assemble16(std::bit_cast<std::uint16_t>(to_integer<std::int16_t>(raw, &saturated)),
                          order);
      break;
    case ValueType::kUint16:
      out[0] = assemble16(to_integer<std::uint16_t>(raw, &saturated), order);
      break;
    case ValueType::kInt32:
      disassemble32(std::bit_cast<std::uint32_t>(to_integer<std::int32_t>(raw, &saturated)), order,
                    out);
      break;
    case ValueType::kUint32:
      disassemble32(to_integer<std::uint32_t>(raw, &saturated), order, out);
      break;
    case ValueType::kFloat32: {
      constexpr double kMax = static_cast<double>(std::numeric_limits<float>::max());
      float f = 0.0f;
      if (raw > kMax) {
        saturated = true;
        f = std::numeric_limits<float>::max();
      } else if (raw < -kMax) {
        saturated = true;
        f = std::numeric_limits<float>::lowest();
      } else {
        f = static_cast<float>(raw);  // round to nearest (default FP environment)
      }
      disassemble32(std::bit_cast<std::uint32_t>(f), order, out);
      break;
    }
  }
  return saturated ? EncodeStatus::kSaturated : EncodeStatus::kOk;
}

}  // namespace hvac_twin::modbus
