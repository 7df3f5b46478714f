// FaultServer: what each fault does to a request or a connection, the black hole, and closing.
// Server thread only, except where noted.
#include <fcntl.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>

#include "tests/fault/fault_server.hpp"
#include "tests/fault/socket_io.hpp"

namespace hvac_twin::test_fault {
namespace {

using detail::send_all;
using Clock = std::chrono::steady_clock;
constexpr std::uint8_t kCloseFin = 1, kCloseReset = 2;

std::uint64_t splitmix(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// A non-blocking connect to the server's own port; returns the socket (or -1).
int connect_filler(std::uint16_t port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd < 0) return -1;
  const sockaddr_in addr = detail::loopback(port);
  (void)::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr);  // EINPROGRESS
  return fd;
}

}  // namespace

std::vector<std::uint16_t> FaultServer::bank(const Request& r, bool poison,
                                             std::size_t count) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto& b = (poison ? poison_ : good_)[r.function == 0x04 ? 1 : 0];
  const auto first = b.begin() + r.address;
  return {first, first + static_cast<std::ptrdiff_t>(count)};
}

Bytes FaultServer::garbage() {
  Bytes bytes(1 + splitmix(rng_) % 64);
  for (auto& b : bytes)
    b = static_cast<std::uint8_t>(splitmix(rng_));
  // Protocol id byte non-zero: whatever else the bytes say, they are never a valid reply.
  if (bytes.size() > 2) bytes[2] |= 0x01;
  return bytes;
}

bool FaultServer::apply(Client& c, const Request& r, const Fault& f) noexcept {
  applied_[static_cast<std::size_t>(f.kind)].fetch_add(1);
  const auto poisoned = [&](const Request& as) { return read_reply(as, bank(r, true, r.count)); };
  Bytes out;
  switch (f.kind) {
    case FaultKind::kResetOnRequest:
      c.close_mode = kCloseReset;
      return false;
    case FaultKind::kFinOnRequest:
      c.close_mode = kCloseFin;
      return false;
    case FaultKind::kGarbage:
      out = garbage();
      break;
    case FaultKind::kWrongTransactionId: {
      Request as = r;
      ++as.transaction_id;
      out = poisoned(as);
      break;
    }
    case FaultKind::kWrongUnitId: {
      Request as = r;
      ++as.unit_id;
      out = poisoned(as);
      break;
    }
    case FaultKind::kWrongFunction: {
      Request as = r;
      as.function = r.function == 0x03 ? 0x04 : 0x03;
      out = poisoned(as);
      break;
    }
    case FaultKind::kBadProtocolId:
      out = poisoned(r);
      put16(out, 2, 1);
      break;
    case FaultKind::kShortFrame: {
      const Bytes full = poisoned(r);
      return send_all(c.fd, full, std::max<std::size_t>(kMbapLength + 1, full.size() / 2));
    }
    case FaultKind::kShortPdu:
      out = read_reply(r, bank(r, true, r.count - 1u));
      break;
    case FaultKind::kDuplicateReply: {
      const Bytes good = read_reply(r, bank(r, false, r.count));
      good_replies_.fetch_add(1);
      if (!send_all(c.fd, good, good.size())) return false;
      out = poisoned(r);
      break;
    }
    case FaultKind::kLateReply:
      delayed_.push_back(Delayed{c.id, Clock::now() + options_.late_reply_delay, poisoned(r)});
      return true;
    case FaultKind::kNoReply:
      return true;
    case FaultKind::kException:
      out = exception_reply(r, f.exception_code);
      break;
    case FaultKind::kResetIdle:
    case FaultKind::kFinIdle:
      return true;  // never queued
  }
  return send_all(c.fd, out, out.size());
}

void FaultServer::apply_idle(bool reset) noexcept {
  if (clients_.empty()) return;  // nothing to break: not counted
  applied_[static_cast<std::size_t>(reset ? FaultKind::kResetIdle : FaultKind::kFinIdle)].fetch_add(
      1);
  while (!clients_.empty()) {
    clients_.back().close_mode = reset ? kCloseReset : kCloseFin;
    close_client(clients_.size() - 1);
  }
}

void FaultServer::send_due() noexcept {
  const auto now = Clock::now();
  for (auto it = delayed_.begin(); it != delayed_.end();) {
    if (it->due > now) {
      ++it;
      continue;
    }
    for (const Client& c : clients_)
      if (c.id == it->client_id) (void)send_all(c.fd, it->bytes, it->bytes.size());
    it = delayed_.erase(it);
  }
}

void FaultServer::close_client(std::size_t index) noexcept {
  Client& c = clients_[index];
  if (c.close_mode == kCloseReset) {
    const linger abort{1, 0};  // close() then sends RST instead of FIN
    ::setsockopt(c.fd, SOL_SOCKET, SO_LINGER, &abort, sizeof abort);
  } else if (c.close_mode == kCloseFin) {
    ::shutdown(c.fd, SHUT_WR);
  }
  ::close(c.fd);
  clients_.erase(clients_.begin() + static_cast<std::ptrdiff_t>(index));
}

void FaultServer::enter_black_hole() noexcept {
  // Runs on run()'s thread, which does not accept while it is here. Fill the accept queue of
  // backlog 0: the first filler completes its handshake into the queue, the second one's SYN is
  // already dropped, and so is every later SYN, the client's included. Only then say so:
  // set_black_hole() returns on this flag, and a client connecting before the queue is full
  // would be let in (seen once in CI: connected after 21 us).
  const int first = connect_filler(port_.load());
  if (first >= 0) {
    pollfd p{first, POLLOUT, 0};
    (void)::poll(&p, 1, 200);
    fillers_.push_back(first);
  }
  const int second = connect_filler(port_.load());
  if (second >= 0) fillers_.push_back(second);
  black_hole_.store(true);  // run() no longer polls the listening socket
}

void FaultServer::leave_black_hole() noexcept {
  // The fillers go first, so what is left in the accept queue reads EOF once accepted.
  for (int fd : fillers_)
    ::close(fd);
  fillers_.clear();
  black_hole_.store(false);
}

}  // namespace hvac_twin::test_fault
