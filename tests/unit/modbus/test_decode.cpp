// Register decoding and encoding against hand-computed register patterns.
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "io/modbus/decode.hpp"
#include "tests/unit/modbus/modbus_test_util.hpp"

using hvac_twin::config::PointConfig;
using hvac_twin::config::ValueType;
using hvac_twin::config::WordOrder;
using namespace hvac_twin::modbus;

namespace {

using Regs = std::vector<std::uint16_t>;

PointConfig point(ValueType type, WordOrder order, double scale = 1.0, double offset = 0.0) {
  PointConfig p = test::holding("p", 0, type, order);
  p.scale = scale;
  p.offset = offset;
  p.range_min = -1e12;
  p.range_max = 1e12;
  return p;
}

DecodeResult dec(const Regs& regs, const PointConfig& p) {
  return decode(regs, p);
}

Regs enc(double value, const PointConfig& p, EncodeStatus expected = EncodeStatus::kOk) {
  Regs out(static_cast<std::size_t>(registers_for(p.type)), 0xDEAD);
  CHECK(encode(value, p, out) == expected);
  return out;
}

constexpr std::array<WordOrder, 4> kAllOrders = {WordOrder::kABCD, WordOrder::kCDAB,
                                                 WordOrder::kBADC, WordOrder::kDCBA};
constexpr std::array<ValueType, 5> kAllTypes = {ValueType::kInt16, ValueType::kUint16,
                                                ValueType::kInt32, ValueType::kUint32,
                                                ValueType::kFloat32};

}  // namespace

TEST_CASE("registers_for and legal word orders") {
  CHECK(registers_for(ValueType::kInt16) == 1);
  CHECK(registers_for(ValueType::kUint16) == 1);
  CHECK(registers_for(ValueType::kInt32) == 2);
  CHECK(registers_for(ValueType::kUint32) == 2);
  CHECK(registers_for(ValueType::kFloat32) == 2);
  for (ValueType t : {ValueType::kInt16, ValueType::kUint16}) {
    CHECK(is_valid_word_order(t, WordOrder::kABCD));
    CHECK(is_valid_word_order(t, WordOrder::kBADC));
    CHECK_FALSE(is_valid_word_order(t, WordOrder::kCDAB));
    CHECK_FALSE(is_valid_word_order(t, WordOrder::kDCBA));
  }
  for (ValueType t : {ValueType::kInt32, ValueType::kUint32, ValueType::kFloat32}) {
    for (WordOrder o : kAllOrders)
      CHECK(is_valid_word_order(t, o));
  }
}

TEST_CASE("16-bit values in AB and BA order") {
  CHECK(dec({0xFFFF}, point(ValueType::kInt16, WordOrder::kABCD)).value == -1.0);
  CHECK(dec({0xFFFF}, point(ValueType::kInt16, WordOrder::kBADC)).value == -1.0);
  CHECK(dec({0xFFFE}, point(ValueType::kInt16, WordOrder::kABCD)).value == -2.0);
  CHECK(dec({0xFEFF}, point(ValueType::kInt16, WordOrder::kBADC)).value == -2.0);
  CHECK(dec({0x8000}, point(ValueType::kInt16, WordOrder::kABCD)).value == -32768.0);
  CHECK(dec({0x1234}, point(ValueType::kUint16, WordOrder::kABCD)).value == 4660.0);
  CHECK(dec({0x3412}, point(ValueType::kUint16, WordOrder::kBADC)).value == 4660.0);
  CHECK(dec({0xFFFF}, point(ValueType::kUint16, WordOrder::kABCD)).value == 65535.0);

  CHECK(enc(-1.0, point(ValueType::kInt16, WordOrder::kABCD)) == Regs{0xFFFF});
  CHECK(enc(-2.0, point(ValueType::kInt16, WordOrder::kBADC)) == Regs{0xFEFF});
  CHECK(enc(4660.0, point(ValueType::kUint16, WordOrder::kBADC)) == Regs{0x3412});
}

TEST_CASE("int32 -2 in all four word orders") {
  const std::vector<std::pair<WordOrder, Regs>> cases = {{WordOrder::kABCD, {0xFFFF, 0xFFFE}},
                                                         {WordOrder::kCDAB, {0xFFFE, 0xFFFF}},
                                                         {WordOrder::kBADC, {0xFFFF, 0xFEFF}},
                                                         {WordOrder::kDCBA, {0xFEFF, 0xFFFF}}};
  for (const auto& [order, regs] : cases) {
    const PointConfig p = point(ValueType::kInt32, order);
    const DecodeResult d = dec(regs, p);
    CHECK(d.status == DecodeStatus::kOk);
    CHECK(d.value == -2.0);
    CHECK(enc(-2.0, p) == regs);
  }
}

TEST_CASE("uint32 0x12345678 in all four word orders") {
  const std::vector<std::pair<WordOrder, Regs>> cases = {{WordOrder::kABCD, {0x1234, 0x5678}},
                                                         {WordOrder::kCDAB, {0x5678, 0x1234}},
                                                         {WordOrder::kBADC, {0x3412, 0x7856}},
                                                         {WordOrder::kDCBA, {0x7856, 0x3412}}};
  for (const auto& [order, regs] : cases) {
    const PointConfig p = point(ValueType::kUint32, order);
    CHECK(dec(regs, p).value == 305419896.0);
    CHECK(enc(305419896.0, p) == regs);
  }
  CHECK(dec({0xFFFF, 0xFFFF}, point(ValueType::kUint32, WordOrder::kABCD)).value == 4294967295.0);
}

TEST_CASE("float32 123.456 in all four word orders") {
  // 123.456f = 0x42F6E979 (bytes A=42 B=F6 C=E9 D=79).
  const std::vector<std::pair<WordOrder, Regs>> cases = {{WordOrder::kABCD, {0x42F6, 0xE979}},
                                                         {WordOrder::kCDAB, {0xE979, 0x42F6}},
                                                         {WordOrder::kBADC, {0xF642, 0x79E9}},
                                                         {WordOrder::kDCBA, {0x79E9, 0xF642}}};
  for (const auto& [order, regs] : cases) {
    const PointConfig p = point(ValueType::kFloat32, order);
    const DecodeResult d = dec(regs, p);
    CHECK(d.status == DecodeStatus::kOk);
    CHECK(d.value == static_cast<double>(123.456f));
    CHECK(d.value == Approx(123.456).epsilon(1e-7));
    CHECK(enc(123.456, p) == regs);
  }
  CHECK(dec({0xBFC0, 0x0000}, point(ValueType::kFloat32, WordOrder::kABCD)).value == -1.5);
}

TEST_CASE("scale and offset give engineering units") {
  // 215 * 0.1 - 10 = 11.5 (e.g. a temperature in 0.1 K steps with an offset)
  const PointConfig p = point(ValueType::kInt16, WordOrder::kABCD, 0.1, -10.0);
  CHECK(dec({215}, p).value == Approx(11.5));
  CHECK(enc(11.5, p) == Regs{215});
  const PointConfig q = point(ValueType::kUint32, WordOrder::kCDAB, 0.001, 0.0);
  CHECK(dec({0x5678, 0x1234}, q).value == Approx(305419.896));
  CHECK(decode_raw(Regs{0x5678, 0x1234}, ValueType::kUint32, WordOrder::kCDAB) == 305419896.0);
}

TEST_CASE("non-finite float32 values are rejected") {
  const PointConfig p = point(ValueType::kFloat32, WordOrder::kABCD);
  CHECK(dec({0x7FC0, 0x0000}, p).status == DecodeStatus::kNotFinite);  // quiet NaN
  CHECK(dec({0x7F80, 0x0001}, p).status == DecodeStatus::kNotFinite);  // signalling NaN
  CHECK(dec({0x7F80, 0x0000}, p).status == DecodeStatus::kNotFinite);  // +Inf
  CHECK(dec({0xFF80, 0x0000}, p).status == DecodeStatus::kNotFinite);  // -Inf
  // Finite raw value whose engineering value overflows.
  const PointConfig huge = point(ValueType::kFloat32, WordOrder::kABCD, 1e300);
  CHECK(dec({0x7F7F, 0xFFFF}, huge).status == DecodeStatus::kNotFinite);
}

TEST_CASE("range check is inclusive and reports the value") {
  PointConfig p = point(ValueType::kInt16, WordOrder::kABCD, 0.5);
  p.range_min = -10.0;
  p.range_max = 10.0;
  CHECK(dec({20}, p).status == DecodeStatus::kOk);  // 10.0 on the bound
  CHECK(dec({static_cast<std::uint16_t>(-20)}, p).status == DecodeStatus::kOk);  // -10.0
  const DecodeResult above = dec({21}, p);
  CHECK(above.status == DecodeStatus::kOutOfRange);
  CHECK(above.value == 10.5);
  CHECK(dec({static_cast<std::uint16_t>(-21)}, p).status == DecodeStatus::kOutOfRange);
  p.range_max = std::numeric_limits<double>::quiet_NaN();
  CHECK(dec({0}, p).status == DecodeStatus::kOutOfRange);
}

TEST_CASE("malformed inputs are reported, never read out of bounds") {
  const PointConfig i32 = point(ValueType::kInt32, WordOrder::kABCD);
  CHECK(dec({}, i32).status == DecodeStatus::kWrongRegisterCount);
  CHECK(dec({1}, i32).status == DecodeStatus::kWrongRegisterCount);
  CHECK(dec({1, 2, 3}, i32).status == DecodeStatus::kWrongRegisterCount);
  CHECK(dec({1}, point(ValueType::kInt16, WordOrder::kCDAB)).status ==
        DecodeStatus::kInvalidWordOrder);
  CHECK(std::isnan(decode_raw(Regs{1}, ValueType::kInt16, WordOrder::kDCBA)));

  Regs one(1, 0xDEAD);
  CHECK(encode(1.0, i32, one) == EncodeStatus::kWrongRegisterCount);
  CHECK(encode(1.0, point(ValueType::kUint16, WordOrder::kDCBA), one) ==
        EncodeStatus::kInvalidWordOrder);
  CHECK(encode(1.0, point(ValueType::kUint16, WordOrder::kABCD, 0.0), one) ==
        EncodeStatus::kInvalidScale);
  CHECK(encode(std::nan(""), point(ValueType::kUint16, WordOrder::kABCD), one) ==
        EncodeStatus::kNotFinite);
  CHECK(one == Regs{0xDEAD});
}

TEST_CASE("encode rounds to nearest and saturates") {
  const PointConfig half = point(ValueType::kInt16, WordOrder::kABCD, 0.5);
  CHECK(enc(1.25, half) == Regs{3});  // raw 2.5 -> 3 (halves away from zero)
  CHECK(enc(-1.25, half) == Regs{static_cast<std::uint16_t>(-3)});
  CHECK(enc(1.2, half) == Regs{2});  // raw 2.4 -> 2

  CHECK(enc(40000.0, point(ValueType::kInt16, WordOrder::kABCD), EncodeStatus::kSaturated) ==
        Regs{0x7FFF});
  CHECK(enc(-40000.0, point(ValueType::kInt16, WordOrder::kABCD), EncodeStatus::kSaturated) ==
        Regs{0x8000});
  CHECK(enc(-1.0, point(ValueType::kUint16, WordOrder::kABCD), EncodeStatus::kSaturated) ==
        Regs{0x0000});
  CHECK(enc(5e9, point(ValueType::kUint32, WordOrder::kABCD), EncodeStatus::kSaturated) ==
        Regs{0xFFFF, 0xFFFF});
  CHECK(enc(-3e9, point(ValueType::kInt32, WordOrder::kABCD), EncodeStatus::kSaturated) ==
        Regs{0x8000, 0x0000});
  CHECK(enc(1e39, point(ValueType::kFloat32, WordOrder::kABCD), EncodeStatus::kSaturated) ==
        Regs{0x7F7F, 0xFFFF});  // FLT_MAX
  CHECK(enc(-1e39, point(ValueType::kFloat32, WordOrder::kABCD), EncodeStatus::kSaturated) ==
        Regs{0xFF7F, 0xFFFF});
  // A tiny scale overflows the raw value to infinity: saturated, not UB.
  CHECK(enc(1e300, point(ValueType::kInt32, WordOrder::kABCD, 1e-300), EncodeStatus::kSaturated) ==
        Regs{0x7FFF, 0xFFFF});
}

TEST_CASE("round trips for every type and word order") {
  const std::vector<std::pair<ValueType, std::vector<double>>> values = {
      {ValueType::kInt16, {0, 1, -1, 32767, -32768, 1234}},
      {ValueType::kUint16, {0, 1, 65535, 4660}},
      {ValueType::kInt32, {0, -1, 2147483647.0, -2147483648.0, 123456789}},
      {ValueType::kUint32, {0, 1, 4294967295.0, 305419896}},
      {ValueType::kFloat32, {0.0, -0.5, 123.456, 1e-20, -3.4e38}}};
  for (const auto& [type, list] : values) {
    for (WordOrder order : kAllOrders) {
      if (!is_valid_word_order(type, order)) continue;
      for (double v : list) {
        for (double scale : {1.0, 0.1, -2.0}) {
          PointConfig p = point(type, order, scale, 3.0);
          p.range_min = -1e300;
          p.range_max = 1e300;
          const double engineering = v * scale + 3.0;
          Regs regs(static_cast<std::size_t>(registers_for(type)));
          REQUIRE(encode(engineering, p, regs) == EncodeStatus::kOk);
          const DecodeResult d = decode(regs, p);
          REQUIRE(d.status == DecodeStatus::kOk);
          if (type == ValueType::kFloat32) {
            CHECK(d.value == Approx(engineering).epsilon(1e-6).margin(1e-30));
          } else {
            CHECK(d.value == Approx(engineering).epsilon(1e-12));
          }
        }
      }
    }
  }
}

TEST_CASE("random registers: decode is total and encode inverts it bit-exactly") {
  std::mt19937 rng(12345);
  std::uniform_int_distribution<int> word(0, 0xFFFF);
  for (int i = 0; i < 20000; ++i) {
    const ValueType type = kAllTypes[static_cast<std::size_t>(i) % kAllTypes.size()];
    const WordOrder order = kAllOrders[static_cast<std::size_t>(i / 5) % kAllOrders.size()];
    if (!is_valid_word_order(type, order)) continue;
    Regs regs(static_cast<std::size_t>(registers_for(type)));
    for (auto& r : regs)
      r = static_cast<std::uint16_t>(word(rng));
    const PointConfig p = point(type, order);
    const DecodeResult d = decode(regs, p);
    if (d.status == DecodeStatus::kNotFinite) {
      CHECK(type == ValueType::kFloat32);
      continue;
    }
    REQUIRE(std::isfinite(d.value));
    Regs back(regs.size());
    REQUIRE(encode(d.value, p, back) == EncodeStatus::kOk);
    // -0.0f decodes to -0.0 and encodes back to the same bits.
    CHECK(back == regs);
  }
}
