// One point's value as the estimator cycle sees it, and the device's poll statistics: what a
// PointSource (the Modbus Poller, or a recording in replay) hands the cycle.
#pragma once

#include <cstdint>

#include "io/modbus/quality.hpp"

namespace hvac_twin::modbus {

struct PointSample {
  double value = 0.0;  // last GOOD engineering value [point unit]; 0 until the first good read
  PointQuality quality = PointQuality::kNotYetRead;
  std::uint8_t exception_code = 0;  // set while quality == kDeviceException, else 0
  std::int64_t read_time_ns = 0;    // CLOCK_MONOTONIC [ns] of the read that gave `value`; 0 = none
};

struct DeviceStatus {
  bool running = false;               // the poller thread is running
  bool connected = false;             // a TCP connection is open
  std::uint64_t polls_ok = 0;         // polls in which every request was answered with data
  std::uint64_t polls_exception = 0;  // polls the device answered, but at least one request
                                      //   with an exception (after the busy retries): those
                                      //   points DEVICE_EXCEPTION, the poll not ok
  std::uint64_t polls_failed = 0;     // polls lost to a transport or gateway failure, or
                                      //   skipped because the device was down
                                      //   (every poll counts once: ok, exception or failed)
  std::uint64_t deadline_misses = 0;  // poll deadlines skipped because a poll overran
  std::uint64_t connect_attempts = 0;
  std::uint64_t connect_failures = 0;
  std::uint64_t reconnects = 0;        // successful connects after a lost connection
  std::uint64_t transport_errors = 0;  // connections dropped after a transport error
  std::uint64_t requests_ok = 0;       // read requests answered with data
  std::uint64_t requests_failed = 0;   // read requests answered with an exception or lost
  std::uint64_t exceptions = 0;        // exception replies (busy retries included)
  std::uint64_t busy_retries = 0;      // requests re-sent after exception 0x06
  std::int64_t last_poll_ok_ns = 0;    // CLOCK_MONOTONIC [ns] end of the last ok poll; 0 = none
  int last_error_number = 0;           // errno / EMB* / kErr* of the last error; 0 = none
  char last_error[96] = {};            // NUL-terminated text of the last error ("" = none)
};

}  // namespace hvac_twin::modbus
