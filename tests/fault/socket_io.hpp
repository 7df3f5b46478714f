// Small socket helpers shared by the fault server's files. Test code; no allocation.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>

#include <cstddef>
#include <cstdint>

#include "tests/fault/fault_frames.hpp"

namespace hvac_twin::test_fault::detail {

// Sends the first `length` bytes at once; false if the kernel took fewer (a few hundred bytes
// always fit a loopback socket's buffer, so that means the connection is gone).
inline bool send_all(int fd, const Bytes& bytes, std::size_t length) {
  const ssize_t n = ::send(fd, bytes.data(), length, MSG_NOSIGNAL | MSG_DONTWAIT);
  return n == static_cast<ssize_t>(length);
}

inline sockaddr_in loopback(std::uint16_t port) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(port);
  return a;
}

}  // namespace hvac_twin::test_fault::detail
