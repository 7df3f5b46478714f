// Network evidence for the DDS Security tests: a private network namespace in which only this
// test's processes talk (so a capture sees nothing else), and a packet capture of its loopback
// interface (AF_PACKET), kept in memory for searching and written as a pcap file for people.
//
// enter_private_network() needs root (CI) or unprivileged user namespaces; it must be called
// while the process is single-threaded, before starting any thread or child process, which then
// all live in the new namespace. Nothing can leave it: its only interface is its own loopback.
#pragma once

#include <arpa/inet.h>
#include <fcntl.h>
#include <linux/if_packet.h>
#include <net/ethernet.h>
#include <net/if.h>
#include <poll.h>
#include <sched.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

namespace hvac_twin::test {

namespace detail {
inline bool write_file(const char* path, const std::string& text) {
  const int fd = ::open(path, O_WRONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool ok = ::write(fd, text.data(), text.size()) == static_cast<ssize_t>(text.size());
  ::close(fd);
  return ok;
}
}  // namespace detail

// Moves this process into a new network namespace and brings its loopback up. Returns "" on
// success, else what failed.
inline std::string enter_private_network() {
  const uid_t uid = ::getuid();
  const gid_t gid = ::getgid();
  if (::unshare(CLONE_NEWNET) != 0) {
    // Without CAP_SYS_ADMIN: a user namespace first, mapping us to root inside it.
    if (::unshare(CLONE_NEWUSER | CLONE_NEWNET) != 0)
      return std::string("unshare(CLONE_NEWNET) failed: ") + std::strerror(errno) +
             " (run as root or allow unprivileged user namespaces)";
    detail::write_file("/proc/self/setgroups", "deny");
    if (!detail::write_file("/proc/self/uid_map", "0 " + std::to_string(uid) + " 1\n") ||
        !detail::write_file("/proc/self/gid_map", "0 " + std::to_string(gid) + " 1\n"))
      return "cannot map the user namespace";
  }
  const int fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return std::string("socket: ") + std::strerror(errno);
  ifreq ifr{};
  std::strncpy(ifr.ifr_name, "lo", IFNAMSIZ - 1);
  bool ok = ::ioctl(fd, SIOCGIFFLAGS, &ifr) == 0;
  ifr.ifr_flags = static_cast<short>(ifr.ifr_flags | IFF_UP);
  ok = ok && ::ioctl(fd, SIOCSIFFLAGS, &ifr) == 0;
  const int err = errno;
  ::close(fd);
  if (!ok) return std::string("cannot bring lo up: ") + std::strerror(err);
  return {};
}

// Captures every frame on `lo` (each once: the outgoing copy is skipped) from construction until
// stop(). Threads: one capture thread; the accessors may be called after stop() only.
class LoopbackCapture {
 public:
  LoopbackCapture() {
    fd_ = ::socket(AF_PACKET, SOCK_RAW | SOCK_CLOEXEC, htons(ETH_P_ALL));
    if (fd_ < 0) {
      error_ = std::string("AF_PACKET socket: ") + std::strerror(errno);
      return;
    }
    const int buffer = 16 << 20;
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUFFORCE, &buffer, sizeof buffer);
    sockaddr_ll addr{};
    addr.sll_family = AF_PACKET;
    addr.sll_protocol = htons(ETH_P_ALL);
    addr.sll_ifindex = static_cast<int>(::if_nametoindex("lo"));
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
      error_ = std::string("bind to lo: ") + std::strerror(errno);
      return;
    }
    thread_ = std::thread([this] { run(); });
  }
  ~LoopbackCapture() {
    stop();
    if (fd_ >= 0) ::close(fd_);
  }
  LoopbackCapture(const LoopbackCapture&) = delete;
  LoopbackCapture& operator=(const LoopbackCapture&) = delete;

  const std::string& error() const { return error_; }  // "" when capturing

  // Stops capturing; returns the number of frames the kernel dropped (0: the capture is whole).
  unsigned stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
    if (fd_ >= 0 && !stats_read_) {
      tpacket_stats stats{};
      socklen_t len = sizeof stats;
      if (::getsockopt(fd_, SOL_PACKET, PACKET_STATISTICS, &stats, &len) == 0)
        drops_ = stats.tp_drops;
      stats_read_ = true;
    }
    return drops_;
  }

  std::size_t frames() const { return frames_.size(); }
  std::size_t frames_containing(std::string_view needle) const {
    std::size_t n = 0;
    for (const auto& f : frames_)
      if (f.data.find(needle) != std::string::npos) ++n;
    return n;
  }

  // How often `needle` occurs in all frames together.
  std::size_t occurrences(std::string_view needle) const {
    std::size_t n = 0;
    for (const auto& f : frames_)
      for (auto at = f.data.find(needle); at != std::string::npos; at = f.data.find(needle, at + 1))
        ++n;
    return n;
  }

  // Writes the frames as a classic pcap file (link type Ethernet), for tcpdump or Wireshark.
  void write_pcap(const std::string& path) const {
    std::ofstream out(path, std::ios::binary);
    const auto put32 = [&](std::uint32_t v) { out.write(reinterpret_cast<const char*>(&v), 4); };
    const auto put16 = [&](std::uint16_t v) { out.write(reinterpret_cast<const char*>(&v), 2); };
    put32(0xa1b2c3d4);
    put16(2);
    put16(4);
    put32(0);
    put32(0);
    put32(262144);
    put32(1);
    for (const auto& f : frames_) {
      put32(static_cast<std::uint32_t>(f.time.tv_sec));
      put32(static_cast<std::uint32_t>(f.time.tv_usec));
      put32(static_cast<std::uint32_t>(f.data.size()));
      put32(static_cast<std::uint32_t>(f.data.size()));
      out.write(f.data.data(), static_cast<std::streamsize>(f.data.size()));
    }
  }

 private:
  struct Frame {
    timeval time;
    std::string data;
  };

  void run() {
    std::vector<char> buf(262144);
    while (!stop_) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 50) <= 0) continue;
      sockaddr_ll from{};
      socklen_t len = sizeof from;
      const ssize_t n =
          ::recvfrom(fd_, buf.data(), buf.size(), 0, reinterpret_cast<sockaddr*>(&from), &len);
      if (n <= 0 || from.sll_pkttype == PACKET_OUTGOING) continue;
      Frame f;
      ::gettimeofday(&f.time, nullptr);
      f.data.assign(buf.data(), static_cast<std::size_t>(n));
      frames_.push_back(std::move(f));
    }
  }

  int fd_ = -1;
  std::string error_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::vector<Frame> frames_;  // capture thread until stop()
  unsigned drops_ = 0;
  bool stats_read_ = false;
};

}  // namespace hvac_twin::test
