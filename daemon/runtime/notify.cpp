#include "daemon/runtime/notify.hpp"

#include <systemd/sd-daemon.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <cstring>

namespace hvac_twin::runtime {

SystemdNotifier::SystemdNotifier() {
  const char* socket = std::getenv("NOTIFY_SOCKET");
  enabled_ = socket != nullptr && socket[0] != '\0';
  std::uint64_t usec = 0;
  if (sd_watchdog_enabled(0, &usec) > 0) watchdog_ns_ = static_cast<std::int64_t>(usec) * 1000;
}

void SystemdNotifier::ready() const {
  if (enabled_) sd_notify(0, "READY=1");
}

void SystemdNotifier::stopping() const {
  if (enabled_) sd_notify(0, "STOPPING=1");
}

void SystemdNotifier::watchdog() const {
  if (enabled_) sd_notify(0, "WATCHDOG=1");
}

void SystemdNotifier::status(std::string_view text) const {
  if (!enabled_) return;
  std::array<char, 208> msg{};
  const std::size_t n = std::min<std::size_t>(text.size(), 200);
  std::memcpy(msg.data(), "STATUS=", 7);
  std::memcpy(msg.data() + 7, text.data(), n);
  sd_notify(0, msg.data());
}

}  // namespace hvac_twin::runtime
