// The systemd notification protocol (sd_notify): READY=1 once start-up is complete, WATCHDOG=1
// after completed cycles, STOPPING=1 at shut-down, STATUS= one line for `systemctl status`.
// Without NOTIFY_SOCKET (not run by systemd) every call is a no-op.
//
// Threads: any; calls are independent datagrams. No exceptions.
#pragma once

#include <cstdint>
#include <string_view>

namespace hvac_twin::runtime {

class SystemdNotifier {
 public:
  SystemdNotifier();  // reads NOTIFY_SOCKET, WATCHDOG_USEC and WATCHDOG_PID

  void ready() const;
  void stopping() const;
  void watchdog() const;
  void status(std::string_view text) const;  // truncated to 200 bytes

  [[nodiscard]] bool enabled() const { return enabled_; }
  // WatchdogSec as CLOCK_MONOTONIC ns, 0 when systemd supervises no watchdog.
  [[nodiscard]] std::int64_t watchdog_interval_ns() const { return watchdog_ns_; }

 private:
  bool enabled_ = false;
  std::int64_t watchdog_ns_ = 0;
};

}  // namespace hvac_twin::runtime
