#include "tests/fault/fault_server.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <stdexcept>
#include <system_error>

#include "tests/fault/socket_io.hpp"

namespace hvac_twin::test_fault {
namespace {

using detail::loopback;
using detail::send_all;
using Clock = std::chrono::steady_clock;
constexpr int kLoopTimeoutMs = 50;

std::system_error sys_error(const char* what) {
  return std::system_error(errno, std::generic_category(), what);
}

}  // namespace

std::string_view to_string(FaultKind kind) noexcept {
  constexpr std::array<std::string_view, kFaultKinds> names = {
      "reset on request", "FIN on request",  "garbage bytes",   "wrong transaction id",
      "wrong unit id",    "wrong function",  "bad protocol id", "short frame",
      "short PDU",        "duplicate reply", "late reply",      "no reply",
      "exception",        "reset when idle", "FIN when idle"};
  const auto i = static_cast<std::size_t>(kind);
  return i < names.size() ? names[i] : "?";
}

FaultServer::FaultServer(FaultServerOptions options) : options_(options), rng_(options.seed) {
  for (int k = 0; k < 2; ++k) {
    good_[k].assign(65536, 0);
    poison_[k].assign(65536, 0);
  }
  port_.store(options_.port);
}

FaultServer::~FaultServer() {
  stop();
}

void FaultServer::start() {
  if (thread_.joinable()) throw std::logic_error("fault server: already running");
  listen_fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (listen_fd_ < 0) throw sys_error("socket");
  const int one = 1;
  ::setsockopt(listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in addr = loopback(port_.load());
  socklen_t length = sizeof addr;
  // Backlog 0: the accept queue holds one connection, so one filler makes it full.
  if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 ||
      ::listen(listen_fd_, 0) != 0 ||
      ::getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&addr), &length) != 0 ||
      ::pipe2(wake_pipe_, O_CLOEXEC | O_NONBLOCK) != 0) {
    const auto error = sys_error("bind/listen on 127.0.0.1");
    ::close(listen_fd_);
    listen_fd_ = -1;
    throw error;
  }
  port_.store(ntohs(addr.sin_port));
  stop_.store(false);
  black_hole_.store(false);
  want_black_hole_.store(false);
  thread_ = std::thread([this] { run(); });
}

void FaultServer::stop() {
  if (!thread_.joinable()) return;
  stop_.store(true);
  wake();
  thread_.join();
  while (!clients_.empty())
    close_client(clients_.size() - 1);
  for (int fd : fillers_)
    ::close(fd);
  fillers_.clear();
  delayed_.clear();
  ::close(listen_fd_);
  ::close(wake_pipe_[0]);
  ::close(wake_pipe_[1]);
  listen_fd_ = wake_pipe_[0] = wake_pipe_[1] = -1;
}

void FaultServer::wake() noexcept {
  const char byte = 1;
  if (wake_pipe_[1] >= 0) (void)!::write(wake_pipe_[1], &byte, 1);
}

void FaultServer::set_registers(config::RegisterKind kind, std::uint16_t address,
                                std::span<const std::uint16_t> values, bool poison) {
  if (std::size_t{address} + values.size() > 65536u)
    throw std::out_of_range("fault server: registers past address 65535");
  std::lock_guard<std::mutex> lock(mutex_);
  auto& bank = (poison ? poison_ : good_)[kind == config::RegisterKind::kInput ? 1 : 0];
  std::copy(values.begin(), values.end(), bank.begin() + address);
}

modbus::EncodeStatus FaultServer::set_value(const config::PointConfig& point, double value,
                                            bool poison) {
  std::array<std::uint16_t, 2> regs{};
  const auto n = static_cast<std::size_t>(modbus::registers_for(point.type));
  const auto status = modbus::encode(value, point, std::span(regs.data(), n));
  if (status == modbus::EncodeStatus::kOk || status == modbus::EncodeStatus::kSaturated)
    set_registers(point.kind, point.address, std::span(regs.data(), n), poison);
  return status;
}

void FaultServer::inject(const Fault& fault) {
  if (fault.kind == FaultKind::kResetIdle || fault.kind == FaultKind::kFinIdle) {
    (fault.kind == FaultKind::kResetIdle ? idle_resets_ : idle_fins_).fetch_add(1);
    wake();
    return;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  queue_.push_back(fault);
}

std::size_t FaultServer::pending_faults() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return queue_.size() + static_cast<std::size_t>(idle_resets_.load() + idle_fins_.load());
}

void FaultServer::set_black_hole(bool on) {
  want_black_hole_.store(on);
  wake();
  const auto end = Clock::now() + std::chrono::seconds(2);
  while (black_hole_.load() != on && Clock::now() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  if (black_hole_.load() != on) throw std::runtime_error("fault server: black hole switch hung");
}

std::uint64_t FaultServer::applied(FaultKind kind) const noexcept {
  return applied_[static_cast<std::size_t>(kind)].load();
}

std::uint64_t FaultServer::applied_total() const noexcept {
  std::uint64_t total = 0;
  for (const auto& a : applied_)
    total += a.load();
  return total;
}

std::uint64_t FaultServer::requests(std::uint8_t function_code) const noexcept {
  return functions_[function_code].load();
}

void FaultServer::run() noexcept {
  std::vector<pollfd> fds;
  while (!stop_.load()) {
    if (idle_resets_.exchange(0) > 0) apply_idle(true);
    if (idle_fins_.exchange(0) > 0) apply_idle(false);
    const bool want = want_black_hole_.load();
    if (want && !black_hole_.load()) enter_black_hole();
    if (!want && black_hole_.load()) leave_black_hole();

    fds.clear();
    fds.push_back({wake_pipe_[0], POLLIN, 0});
    fds.push_back({black_hole_.load() ? -1 : listen_fd_, POLLIN, 0});  // -1: not polled
    for (const Client& c : clients_)
      fds.push_back({c.fd, POLLIN, 0});
    int timeout = kLoopTimeoutMs;
    for (const Delayed& d : delayed_) {
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(d.due - Clock::now()).count();
      timeout = std::clamp(static_cast<int>(left) + 1, 0, timeout);
    }
    if (::poll(fds.data(), fds.size(), timeout) < 0) continue;  // EINTR
    char drain[64];
    while (::read(wake_pipe_[0], drain, sizeof drain) > 0) {
    }
    send_due();
    // From the back, so closing a client does not shift the ones still to visit.
    for (std::size_t i = clients_.size(); i-- > 0;) {
      if (fds[2 + i].revents != 0 && !read_client(clients_[i])) close_client(i);
    }
    if ((fds[1].revents & POLLIN) != 0) accept_all();
    clients_now_.store(clients_.size());
  }
}

void FaultServer::accept_all() noexcept {
  for (;;) {
    const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC | SOCK_NONBLOCK);
    if (fd < 0) return;
    accepted_.fetch_add(1);
    clients_.push_back(Client{fd, next_client_id_++, {}, 0});
  }
}

bool FaultServer::read_client(Client& c) noexcept {
  std::uint8_t buffer[512];
  const ssize_t n = ::recv(c.fd, buffer, sizeof buffer, MSG_DONTWAIT);
  if (n == 0) return false;
  if (n < 0) return errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR;
  c.in.insert(c.in.end(), buffer, buffer + n);
  for (;;) {
    bool invalid = false;
    const auto length = frame_length(c.in, &invalid);
    if (invalid) return false;
    if (!length || c.in.size() < *length) return true;
    const Bytes adu(c.in.begin(), c.in.begin() + static_cast<std::ptrdiff_t>(*length));
    c.in.erase(c.in.begin(), c.in.begin() + static_cast<std::ptrdiff_t>(*length));
    if (!handle(c, adu)) return false;
  }
}

bool FaultServer::handle(Client& c, std::span<const std::uint8_t> adu) noexcept {
  const auto request = parse_request(adu);
  if (!request) return true;
  functions_[request->function].fetch_add(1);
  if (black_hole_.load()) {
    black_holed_.fetch_add(1);
    return true;
  }
  const Request& r = *request;
  if (!r.is_read()) return send_all(c.fd, exception_reply(r, 0x01), 9);
  if (r.unit_id != options_.unit_id) return send_all(c.fd, exception_reply(r, 0x0B), 9);
  if (r.count == 0 || r.count > 125) return send_all(c.fd, exception_reply(r, 0x03), 9);
  if (std::size_t{r.address} + r.count > 65536u) return send_all(c.fd, exception_reply(r, 0x02), 9);
  Fault fault;
  bool faulty = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!queue_.empty()) {
      fault = queue_.front();
      queue_.pop_front();
      faulty = true;
    }
  }
  if (faulty) return apply(c, r, fault);
  const Bytes reply = read_reply(r, bank(r, false, r.count));
  good_replies_.fetch_add(1);
  return send_all(c.fd, reply, reply.size());
}

}  // namespace hvac_twin::test_fault
