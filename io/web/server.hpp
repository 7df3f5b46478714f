// The HTTP side of hvac-twin-web (cpp-httplib, Debian's libcpp-httplib-dev 0.11): the page, its
// JSON API and the Server-Sent Event streams, all GET; every other method is refused (405).
//
//   GET /                       the page (embedded assets, assets.hpp)
//   GET /api/overview           every unit's summary (json.hpp)
//   GET /api/unit?site=&unit=   everything latest of one unit
//   GET /api/history?site=&unit=&window=SECONDS[&points=N]
//   GET /events[?site=&unit=]   event stream: summaries (and that unit's records)
//   GET /healthz                "ok"
//
// Each request is checked in this order: Host header (auth.hpp host_allowed: 403), method
// (405), credentials (401 with a basic-auth challenge). Every response carries a strict
// Content-Security-Policy (same origin only), nosniff, no referrer, no framing, no caching.
//
// Why cpp-httplib: packaged in bookworm, small, blocking and thread-per-connection, which fits a
// read-only dashboard with a few dozen clients; TLS through OpenSSL is built into Debian's build.
// civetweb would serve as well but brings its own C API and configuration strings; Boost.Beast
// means writing the HTTP server itself on asio. Its 0.11 has no WebSocket, and needs none: the
// updates flow one way, which is what Server-Sent Events are (and EventSource reconnects by
// itself).
//
// Threads: the listener runs on a thread of its own, requests on a pool of max_clients + 8
// threads (an event stream holds one for as long as it is open). Construct, start() and stop()
// from one thread. Allocation: everywhere; not a real-time path.
#pragma once

#include <chrono>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "io/web/auth.hpp"
#include "io/web/dashboard.hpp"
#include "io/web/options.hpp"

namespace httplib {
class Server;
}

namespace hvac_twin::web {

struct ServerConfig {
  ListenAddress listen;
  Credentials credentials;
  std::optional<std::string> tls_certificate;  // resolved paths; both or neither
  std::optional<std::string> tls_private_key;
  std::vector<std::string> allowed_hosts;
  std::size_t max_clients = 32;
  std::chrono::seconds keepalive{15};     // an SSE comment at least this often
  std::chrono::seconds write_timeout{5};  // a browser that takes no data this long is dropped
};

// The TLS files cannot be used; what() names them and OpenSSL's reason.
struct TlsError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class Server {
 public:
  // Creates the server and binds the listening socket. Throws TlsError for unusable TLS files,
  // std::runtime_error "cannot listen on HOST:PORT: reason" when binding fails.
  Server(ServerConfig config, Dashboard& dashboard);
  ~Server();  // stop()
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  int port() const noexcept { return port_; }
  std::string url() const;  // "http://127.0.0.1:8080/"

  void start();  // accepts connections on a thread of its own
  void stop();   // closes the streams, stops accepting, joins; idempotent

 private:
  void routes();

  ServerConfig config_;
  Dashboard& dashboard_;
  std::unique_ptr<httplib::Server> http_;
  int port_ = 0;
  std::thread thread_;
};

}  // namespace hvac_twin::web
