#include "tests/support/modbus_test_server.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <modbus/modbus.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <stdexcept>
#include <system_error>

namespace hvac_twin::test_support {
namespace {

constexpr int kHeaderLength = 7;  // MBAP: transaction id, protocol id, length, unit id
constexpr int kLoopTimeoutMs = 50;

std::system_error sys_error(const char* what) {
  return std::system_error(errno, std::generic_category(), what);
}

}  // namespace

ModbusTestServer::ModbusTestServer(ModbusTestServerOptions options) : options_(options) {
  if (options_.unit_id < 0 || options_.unit_id > 255) {
    throw std::invalid_argument("test server: unit_id must be in 0..255");
  }
  if (options_.holding_registers < 0 || options_.holding_registers > 65536 ||
      options_.input_registers < 0 || options_.input_registers > 65536 ||
      options_.max_clients < 1) {
    throw std::invalid_argument("test server: bad register counts or max_clients");
  }
  mapping_ = modbus_mapping_new(0, 0, options_.holding_registers, options_.input_registers);
  if (mapping_ == nullptr) throw sys_error("modbus_mapping_new");
  port_.store(options_.port);
}

ModbusTestServer::~ModbusTestServer() {
  stop();
  modbus_mapping_free(mapping_);
}

void ModbusTestServer::start() {
  if (running_.load()) throw std::logic_error("test server: already running");
  ctx_ = modbus_new_tcp("127.0.0.1", port_.load());
  if (ctx_ == nullptr) throw sys_error("modbus_new_tcp");
  // The poll() loop only reads a client that has data, so the indication timeout is a safety
  // net; the byte timeout bounds how long a half-sent request can hold the loop.
  modbus_set_indication_timeout(ctx_, 0, 200'000);
  modbus_set_byte_timeout(ctx_, 0, 100'000);
  listen_fd_ = modbus_tcp_listen(ctx_, options_.max_clients);  // sets SO_REUSEADDR
  if (listen_fd_ < 0) {
    const auto error = sys_error("modbus_tcp_listen on 127.0.0.1");
    modbus_free(ctx_);
    ctx_ = nullptr;
    throw error;
  }
  // Non-blocking, so a connection reset between poll() and accept() cannot hang the loop.
  fcntl(listen_fd_, F_SETFL, fcntl(listen_fd_, F_GETFL) | O_NONBLOCK);
  sockaddr_in bound{};
  socklen_t length = sizeof bound;
  if (getsockname(listen_fd_, reinterpret_cast<sockaddr*>(&bound), &length) != 0 ||
      pipe2(wake_pipe_, O_CLOEXEC | O_NONBLOCK) != 0) {
    const auto error = sys_error("getsockname/pipe2");
    ::close(listen_fd_);
    listen_fd_ = -1;
    modbus_free(ctx_);
    ctx_ = nullptr;
    throw error;
  }
  port_.store(ntohs(bound.sin_port));
  clients_.clear();
  clients_.reserve(static_cast<std::size_t>(options_.max_clients));
  stop_.store(false);
  running_.store(true);
  thread_ = std::thread([this] { run(); });
}

void ModbusTestServer::stop() {
  if (!thread_.joinable()) return;
  stop_.store(true);
  wake();
  thread_.join();
  close_clients();
  ::close(listen_fd_);
  listen_fd_ = -1;
  ::close(wake_pipe_[0]);
  ::close(wake_pipe_[1]);
  wake_pipe_[0] = wake_pipe_[1] = -1;
  modbus_set_socket(ctx_, -1);  // the client sockets are ours, already closed
  modbus_free(ctx_);
  ctx_ = nullptr;
  running_.store(false);
}

void ModbusTestServer::wake() noexcept {
  const char byte = 1;
  if (wake_pipe_[1] >= 0) (void)!::write(wake_pipe_[1], &byte, 1);
}

void ModbusTestServer::close_clients() noexcept {
  for (int fd : clients_)
    ::close(fd);
  clients_.clear();
  clients_now_.store(0);
}

void ModbusTestServer::run() noexcept {
  std::vector<pollfd> fds;
  fds.reserve(clients_.capacity() + 2);
  while (!stop_.load()) {
    if (drop_clients_.exchange(false)) close_clients();
    fds.clear();
    fds.push_back({wake_pipe_[0], POLLIN, 0});
    fds.push_back({listen_fd_, POLLIN, 0});
    for (int fd : clients_)
      fds.push_back({fd, POLLIN, 0});
    const int rc = ::poll(fds.data(), fds.size(), kLoopTimeoutMs);
    if (rc < 0) continue;  // EINTR
    if (fds[0].revents != 0) {
      char drain[64];
      while (::read(wake_pipe_[0], drain, sizeof drain) > 0) {
      }
      continue;  // re-check stop_ and drop_clients_
    }
    // Serve clients before accepting, so that fds[] still matches clients_.
    std::vector<int> closed;
    for (std::size_t i = 2; i < fds.size(); ++i) {
      if (fds[i].revents != 0 && !serve_one(fds[i].fd)) closed.push_back(fds[i].fd);
    }
    for (int fd : closed) {
      ::close(fd);
      clients_.erase(std::find(clients_.begin(), clients_.end(), fd));
    }
    if ((fds[1].revents & POLLIN) != 0) {
      for (;;) {
        const int fd = ::accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
        if (fd < 0) break;
        accepted_.fetch_add(1);
        if (clients_.size() >= static_cast<std::size_t>(options_.max_clients)) {
          ::close(fd);
        } else {
          clients_.push_back(fd);
        }
      }
    }
    clients_now_.store(clients_.size());
  }
}

bool ModbusTestServer::serve_one(int fd) noexcept {
  std::uint8_t request[MODBUS_TCP_MAX_ADU_LENGTH];
  modbus_set_socket(ctx_, fd);
  const int length = modbus_receive(ctx_, request);
  if (length < 0) return false;  // closed by the peer, reset, timeout or garbage
  if (length <= kHeaderLength) return true;
  function_counts_[request[kHeaderLength]].fetch_add(1);

  ServerFaults faults;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    faults = faults_;
    if (faults_.forced_exception != 0 && faults_.forced_exception_budget > 0) {
      --faults_.forced_exception_budget;
    }
  }
  if (request[kHeaderLength - 1] != options_.unit_id) {
    switch (options_.unit_id_policy) {
      case UnitIdPolicy::kIgnore:
        return true;
      case UnitIdPolicy::kGatewayException:
        return modbus_reply_exception(ctx_, request, MODBUS_EXCEPTION_GATEWAY_TARGET) >= 0;
      case UnitIdPolicy::kAnswerAny:
        break;
    }
  }
  if (faults.drop_requests) return true;
  // The reply echoes the request's header, so faults are injected by editing the request.
  if (faults.reply_unit_id >= 0)
    request[kHeaderLength - 1] = static_cast<std::uint8_t>(faults.reply_unit_id);
  if (faults.transaction_id_delta != 0) {
    const auto tid =
        static_cast<std::uint16_t>(((request[0] << 8) | request[1]) + faults.transaction_id_delta);
    request[0] = static_cast<std::uint8_t>(tid >> 8);
    request[1] = static_cast<std::uint8_t>(tid & 0xFF);
  }
  if (faults.forced_exception != 0 && faults.forced_exception_budget != 0) {
    return modbus_reply_exception(ctx_, request, faults.forced_exception) >= 0;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  return modbus_reply(ctx_, request, length, mapping_) >= 0;
}

void ModbusTestServer::set_registers(config::RegisterKind kind, std::uint16_t address,
                                     std::span<const std::uint16_t> values) {
  std::lock_guard<std::mutex> lock(mutex_);
  const bool input = kind == config::RegisterKind::kInput;
  const int size = input ? mapping_->nb_input_registers : mapping_->nb_registers;
  if (std::size_t{address} + values.size() > static_cast<std::size_t>(size)) {
    throw std::out_of_range("test server: set_registers beyond the served addresses");
  }
  std::uint16_t* table = input ? mapping_->tab_input_registers : mapping_->tab_registers;
  std::copy(values.begin(), values.end(), table + address);
}

void ModbusTestServer::get_registers(config::RegisterKind kind, std::uint16_t address,
                                     std::span<std::uint16_t> out) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const bool input = kind == config::RegisterKind::kInput;
  const int size = input ? mapping_->nb_input_registers : mapping_->nb_registers;
  if (std::size_t{address} + out.size() > static_cast<std::size_t>(size)) {
    throw std::out_of_range("test server: get_registers beyond the served addresses");
  }
  const std::uint16_t* table = input ? mapping_->tab_input_registers : mapping_->tab_registers;
  std::copy_n(table + address, out.size(), out.begin());
}

modbus::EncodeStatus ModbusTestServer::set_value(const config::PointConfig& point,
                                                 double engineering_value) {
  std::array<std::uint16_t, 2> regs{};
  const auto n = static_cast<std::size_t>(modbus::registers_for(point.type));
  const auto status = modbus::encode(engineering_value, point, std::span(regs.data(), n));
  if (status == modbus::EncodeStatus::kOk || status == modbus::EncodeStatus::kSaturated) {
    set_registers(point.kind, point.address, std::span<const std::uint16_t>(regs.data(), n));
  }
  return status;
}

void ModbusTestServer::set_faults(const ServerFaults& faults) {
  std::lock_guard<std::mutex> lock(mutex_);
  faults_ = faults;
}

ServerFaults ModbusTestServer::faults() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return faults_;
}

void ModbusTestServer::disconnect_clients() {
  drop_clients_.store(true);
  wake();
}

std::uint64_t ModbusTestServer::request_count(std::uint8_t function_code) const noexcept {
  return function_counts_[function_code].load();
}

std::uint64_t ModbusTestServer::total_requests() const noexcept {
  std::uint64_t total = 0;
  for (const auto& c : function_counts_)
    total += c.load();
  return total;
}

}  // namespace hvac_twin::test_support
