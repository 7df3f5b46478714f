// Plays systemd's side of the notification protocol: an AF_UNIX datagram socket whose path is
// exported as NOTIFY_SOCKET, collecting what the process under test sends.
#pragma once

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <vector>

namespace hvac_twin::test {

class NotifySocket {
 public:
  NotifySocket() {
    path_ =
        "/tmp/hvac-twin-notify-" + std::to_string(::getpid()) + "-" + std::to_string(counter()++);
    ::unlink(path_.c_str());
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path_.c_str());
    if (fd_ < 0 || ::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0)
      throw std::runtime_error("cannot bind notify socket " + path_);
  }
  ~NotifySocket() {
    ::close(fd_);
    ::unlink(path_.c_str());
  }
  NotifySocket(const NotifySocket&) = delete;
  NotifySocket& operator=(const NotifySocket&) = delete;

  const std::string& path() const { return path_; }

  // Every message received within `timeout` (returns early once `until` appears, if given).
  std::vector<std::string> receive(std::chrono::milliseconds timeout, const char* until = nullptr) {
    std::vector<std::string> out;
    const auto end = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < end) {
      pollfd p{fd_, POLLIN, 0};
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
          end - std::chrono::steady_clock::now());
      if (::poll(&p, 1, static_cast<int>(std::max<long>(0, left.count()))) <= 0) continue;
      char buf[512];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) continue;
      out.emplace_back(buf, static_cast<std::size_t>(n));
      if (until != nullptr && out.back().find(until) != std::string::npos) break;
    }
    return out;
  }

 private:
  static int& counter() {
    static int c = 0;
    return c;
  }
  std::string path_;
  int fd_ = -1;
};

}  // namespace hvac_twin::test
