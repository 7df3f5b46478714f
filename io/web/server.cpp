#include "io/web/server.hpp"

#include <httplib.h>
#include <openssl/err.h>
#include <sys/socket.h>

#include <cerrno>
#include <charconv>
#include <cstring>
#include <fstream>

#include "io/web/assets.hpp"

namespace hvac_twin::web {
namespace {

using Clock = std::chrono::steady_clock;

std::int64_t monotonic_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch())
      .count();
}

std::int64_t realtime_ms() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

constexpr const char* kSecurityPolicy =
    "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self'; "
    "connect-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'";

void text(httplib::Response& res, int status, const std::string& body) {
  res.status = status;
  res.set_header("Cache-Control", "no-store");
  res.set_content(body + "\n", "text/plain; charset=utf-8");
}

void json(httplib::Response& res, const std::string& body) {
  res.status = 200;
  res.set_header("Cache-Control", "no-store");
  res.set_content(body, "application/json");
}

// A whole number of `param` within [min, max], else `fallback`.
long long param(const httplib::Request& req, const char* name, long long fallback, long long min,
                long long max) {
  if (!req.has_param(name)) return fallback;
  const std::string v = req.get_param_value(name);
  long long n = 0;
  const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), n);
  if (ec != std::errc{} || end != v.data() + v.size()) return fallback;
  return std::clamp(n, min, max);
}

// The file must exist and be readable by us before OpenSSL gets it: a clear message otherwise.
void check_readable(const char* option, const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in || in.peek() == std::ifstream::traits_type::eof())
    throw TlsError(std::string(option) + ": cannot read '" + path +
                   "': " + (in ? "empty file" : std::strerror(errno)));
}

std::string openssl_errors() {
  std::string out;
  while (const unsigned long e = ERR_get_error()) {
    char buffer[256];
    ERR_error_string_n(e, buffer, sizeof buffer);
    if (!out.empty()) out += "; ";
    out += buffer;
  }
  return out.empty() ? "no reason given" : out;
}

// What a stream's provider keeps between its calls.
struct Stream {
  std::shared_ptr<Hub::Client> client;
  bool started = false;
  Clock::time_point last_write = Clock::now();
};

}  // namespace

Server::Server(ServerConfig config, Dashboard& dashboard)
    : config_(std::move(config)), dashboard_(dashboard) {
  if (config_.tls_certificate) {
    check_readable("--tls-certificate", *config_.tls_certificate);
    check_readable("--tls-private-key", *config_.tls_private_key);
    ERR_clear_error();
    http_ = std::make_unique<httplib::SSLServer>(config_.tls_certificate->c_str(),
                                                 config_.tls_private_key->c_str());
    if (!http_->is_valid()) {
      throw TlsError("TLS: OpenSSL refused the certificate '" + *config_.tls_certificate +
                     "' or its private key '" + *config_.tls_private_key +
                     "': " + openssl_errors());
    }
  } else {
    http_ = std::make_unique<httplib::Server>();
  }
  const std::size_t threads = config_.max_clients + 8;
  http_->new_task_queue = [threads] { return new httplib::ThreadPool(threads); };
  http_->set_keep_alive_timeout(5);
  http_->set_read_timeout(10);
  http_->set_write_timeout(config_.write_timeout);
  http_->set_payload_max_length(64 * 1024);  // GET only: nothing large ever comes in
  // SO_REUSEADDR only: cpp-httplib's default adds SO_REUSEPORT, with which a second process
  // (another instance, or anyone's) could bind the same port and take half the connections.
  http_->set_socket_options([](int sock) {
    int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  http_->set_default_headers({{"Content-Security-Policy", kSecurityPolicy},
                              {"X-Content-Type-Options", "nosniff"},
                              {"Referrer-Policy", "no-referrer"},
                              {"X-Frame-Options", "DENY"}});
  routes();
  errno = 0;
  if (config_.listen.port == 0) {
    port_ = http_->bind_to_any_port(config_.listen.host);
  } else {
    port_ =
        http_->bind_to_port(config_.listen.host, config_.listen.port) ? config_.listen.port : -1;
  }
  if (port_ <= 0) {
    const int error = errno;
    throw std::runtime_error("cannot listen on " + config_.listen.url_host() + ":" +
                             std::to_string(config_.listen.port) + ": " +
                             (error != 0 ? std::strerror(error) : "bind failed"));
  }
}

Server::~Server() {
  stop();
}

std::string Server::url() const {
  return std::string(config_.tls_certificate ? "https" : "http") + "://" +
         config_.listen.url_host() + ":" + std::to_string(port_) + "/";
}

void Server::start() {
  thread_ = std::thread([this] { http_->listen_after_bind(); });
  // Until the listener runs, cpp-httplib's stop() does nothing: a stop() right after start()
  // would leave the thread listening and join() waiting for ever.
  while (!http_->is_running())
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
}

void Server::stop() {
  dashboard_.hub().close();  // ends the event streams, which hold pool threads
  if (http_) http_->stop();
  if (thread_.joinable()) thread_.join();
}

void Server::routes() {
  http_->set_pre_routing_handler([this](const httplib::Request& req, httplib::Response& res) {
    if (!host_allowed(req.get_header_value("Host"), config_.allowed_hosts)) {
      text(res, 403,
           "host '" + req.get_header_value("Host") +
               "' is not served here (hvac-twin-web --allow-host NAME adds a name)");
      return httplib::Server::HandlerResponse::Handled;
    }
    if (req.method != "GET" && req.method != "HEAD") {
      res.set_header("Allow", "GET, HEAD");
      text(res, 405, "read-only: GET and HEAD only");
      return httplib::Server::HandlerResponse::Handled;
    }
    const Auth auth = authorize(config_.credentials, req.get_header_value("Authorization"));
    if (auth != Auth::kAllowed) {
      res.set_header("WWW-Authenticate", "Basic realm=\"hvac-twin\", charset=\"UTF-8\"");
      text(res, 401, auth == Auth::kMissing ? "credentials required" : "wrong credentials");
      return httplib::Server::HandlerResponse::Handled;
    }
    return httplib::Server::HandlerResponse::Unhandled;
  });

  http_->Get("/api/overview", [this](const httplib::Request&, httplib::Response& res) {
    json(res, dashboard_.overview(monotonic_ns()));
  });
  http_->Get("/api/unit", [this](const httplib::Request& req, httplib::Response& res) {
    const auto body =
        dashboard_.unit(req.get_param_value("site"), req.get_param_value("unit"), monotonic_ns());
    if (!body) return text(res, 404, "no such unit");
    json(res, *body);
  });
  http_->Get("/api/history", [this](const httplib::Request& req, httplib::Response& res) {
    HistoryRequest h;
    h.now_ms = realtime_ms();
    h.window_ms = param(req, "window", 3600, 60, 31 * 86400) * 1000;
    h.max_points = static_cast<std::size_t>(param(req, "points", 300, 10, 2000));
    const auto body =
        dashboard_.history(req.get_param_value("site"), req.get_param_value("unit"), h);
    if (!body) return text(res, 404, "no such unit");
    json(res, *body);
  });
  http_->Get("/healthz",
             [](const httplib::Request&, httplib::Response& res) { text(res, 200, "ok"); });

  http_->Get("/events", [this](const httplib::Request& req, httplib::Response& res) {
    const std::string key = req.has_param("unit")
                                ? unit_key(req.get_param_value("site"), req.get_param_value("unit"))
                                : std::string();
    auto stream = std::make_shared<Stream>();
    stream->client = dashboard_.hub().subscribe(key);
    if (!stream->client) return text(res, 503, "too many event streams open");
    res.set_header("Cache-Control", "no-store");
    res.set_header("X-Accel-Buffering", "no");  // a reverse proxy must not buffer the stream
    res.set_chunked_content_provider(
        "text/event-stream",
        [this, stream](std::size_t, httplib::DataSink& sink) {
          std::string out;
          if (!stream->started) {  // reconnect after 2 s; the page fetches the state on "hello"
            stream->started = true;
            out = "retry: 2000\n" + sse_event("hello", "{}");
          }
          Hub& hub = dashboard_.hub();
          Event event;
          // Up to 1 s per call, so a stopping server is noticed; then whatever else is queued.
          auto wait = std::chrono::milliseconds(out.empty() ? 1000 : 0);
          for (int batch = 0; batch < 256; ++batch) {
            const Hub::Next next = hub.next(*stream->client, wait, event);
            wait = std::chrono::milliseconds(0);
            if (next == Hub::Next::kClosed) return false;
            if (next == Hub::Next::kTimeout) break;
            if (next == Hub::Next::kResync) out += sse_event("resync", "{}");
            if (next == Hub::Next::kEvent) out += *event;
          }
          if (out.empty() && Clock::now() - stream->last_write >= config_.keepalive)
            out = ": keepalive\n\n";
          if (out.empty()) return true;
          stream->last_write = Clock::now();
          return sink.write(out.data(), out.size());
        },
        [this, stream](bool) { dashboard_.hub().unsubscribe(stream->client); });
  });

  // The page's files: the embedded assets; anything else is 404.
  http_->Get(R"(/[A-Za-z0-9._-]*)", [](const httplib::Request& req, httplib::Response& res) {
    std::string_view path = req.path;
    if (path == "/favicon.ico") path = "/favicon.svg";
    const Asset* asset = find_asset(path);
    if (!asset) return text(res, 404, "not found");
    res.set_header("Cache-Control", "no-cache");
    res.set_content(asset->body.data(), asset->body.size(), std::string(asset->content_type));
  });
}

}  // namespace hvac_twin::web
