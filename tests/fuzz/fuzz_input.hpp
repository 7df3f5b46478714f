// Reads typed values off the front of a fuzzer's input, zero-filling past its end, so that every
// input of any length decodes into some parameter set. Header-only, no allocation.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>

namespace hvac_twin::fuzz {

class InputReader {
 public:
  InputReader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  template <typename T>
  T take() {
    T value{};
    std::uint8_t bytes[sizeof(T)] = {};
    const std::size_t n = size_ - pos_ < sizeof(T) ? size_ - pos_ : sizeof(T);
    if (n > 0) std::memcpy(bytes, data_ + pos_, n);
    pos_ += n;
    std::memcpy(&value, bytes, sizeof(T));
    return value;
  }
  std::uint16_t take_be16() {
    const auto hi = take<std::uint8_t>();
    const auto lo = take<std::uint8_t>();
    return static_cast<std::uint16_t>((hi << 8) | lo);
  }
  std::span<const std::uint8_t> rest() const { return {data_ + pos_, size_ - pos_}; }
  bool empty() const { return pos_ >= size_; }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

// Aborts with a message: how a target reports a broken invariant to libFuzzer (as a crash).
[[noreturn]] void invariant_failed(const char* what);

}  // namespace hvac_twin::fuzz

#define HVAC_TWIN_FUZZ_CHECK(condition) \
  ((condition) ? (void)0 : ::hvac_twin::fuzz::invariant_failed(#condition))
