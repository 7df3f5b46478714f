// Quality of one Modbus point, as seen by the estimator. Header-only, no allocation; any thread.
//
//   kNotYetRead --first read--> kGood <--age--> kStale
//        |                        |
//        +--> kCommFail (device down or transport error; the last good value is kept)
//        +--> kDeviceException (the device answered the request with an exception code)
//        +--> kOutOfRange (decoded value not finite or outside [range_min, range_max])
//
// kStale is never stored: Poller::snapshot() derives it from the age of the last good read at the
// caller's `now`. The filter fuses only kGood points.
#pragma once

#include <cstdint>
#include <string_view>

namespace hvac_twin::modbus {

enum class PointQuality : std::uint8_t {
  kNotYetRead,       // no read attempted or answered yet since start
  kGood,             // last read decoded, finite and in range, and younger than stale_after_s
  kStale,            // last read was good but is older than stale_after_s
  kCommFail,         // device down / transport error; value is the last good one (if any)
  kDeviceException,  // the device answered with a Modbus exception (see exception_code)
  kOutOfRange,       // decoded value not finite or outside the configured physical range
};

// Upper-case protocol-style name, e.g. "COMM_FAIL". Static storage; never allocates.
constexpr std::string_view to_string(PointQuality q) noexcept {
  switch (q) {
    case PointQuality::kNotYetRead:
      return "NOT_YET_READ";
    case PointQuality::kGood:
      return "GOOD";
    case PointQuality::kStale:
      return "STALE";
    case PointQuality::kCommFail:
      return "COMM_FAIL";
    case PointQuality::kDeviceException:
      return "DEVICE_EXCEPTION";
    case PointQuality::kOutOfRange:
      return "OUT_OF_RANGE";
  }
  return "UNKNOWN";
}

}  // namespace hvac_twin::modbus
