// hvac-twin-web: the live web dashboard of the hvac-twin DDS topics. See --help and README.md.
#include <atomic>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>

#include "io/dds/cli/options.hpp"
#include "io/dds/participant.hpp"
#include "io/dds/security.hpp"
#include "io/dds/subscriber.hpp"
#include "io/web/auth.hpp"
#include "io/web/dashboard.hpp"
#include "io/web/feed.hpp"
#include "io/web/options.hpp"
#include "io/web/server.hpp"

namespace {

constexpr int kExitOk = 0;
constexpr int kExitFailure = 1;
constexpr int kExitUsage = 64;   // EX_USAGE
constexpr int kExitConfig = 78;  // EX_CONFIG: credentials or TLS files; a restart will not help

std::atomic<bool> g_stop{false};

extern "C" void on_signal(int /*signal*/) {
  g_stop.store(true);
}

void install_signal_handlers() {
  struct sigaction action {};
  action.sa_handler = on_signal;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, nullptr);
  sigaction(SIGTERM, &action, nullptr);
  // A browser that went away makes a write fail with EPIPE; the signal would end the process.
  signal(SIGPIPE, SIG_IGN);
}

// The server's configuration with every file read and resolved; throws CredentialsError or
// std::runtime_error (exit 78).
hvac_twin::web::ServerConfig server_config(const hvac_twin::web::Options& o) {
  namespace web = hvac_twin::web;
  const char* credentials = std::getenv("CREDENTIALS_DIRECTORY");
  web::ServerConfig c;
  c.listen = o.listen;
  c.credentials = web::load_credentials(o.basic_auth_file, o.token_file, credentials);
  if (o.tls_certificate) {
    c.tls_certificate =
        hvac_twin::dds::resolve_security_path("--tls-certificate", *o.tls_certificate, credentials);
    c.tls_private_key =
        hvac_twin::dds::resolve_security_path("--tls-private-key", *o.tls_private_key, credentials);
  }
  c.allowed_hosts = o.allowed_hosts;
  c.max_clients = o.max_clients;
  return c;
}

int run(hvac_twin::web::Options& options) {
  namespace web = hvac_twin::web;
  namespace dds = hvac_twin::dds;
  web::ServerConfig config;
  try {
    config = server_config(options);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hvac-twin-web: %s\n", e.what());
    return kExitConfig;
  }
  const bool open = !config.credentials.required();
  const bool plain = !config.tls_certificate;
  web::StoreLimits limits;
  limits.max_units = options.max_units;
  limits.fine_capacity = options.history_samples;
  limits.minute_capacity = options.history_minutes;
  web::HubLimits hub;
  hub.max_clients = options.max_clients;
  web::Dashboard dashboard(limits, hub);

  std::unique_ptr<web::Server> server;
  try {
    server = std::make_unique<web::Server>(std::move(config), dashboard);
  } catch (const web::TlsError& e) {
    std::fprintf(stderr, "hvac-twin-web: %s\n", e.what());
    return kExitConfig;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hvac-twin-web: %s\n", e.what());
    return kExitFailure;
  }
  try {
    dds::cli::make_security_paths_absolute(options.dds);
    const std::unique_ptr<dds::Participant> participant = dds::make_participant(options.dds);
    dds::Subscriber subscriber(*participant, options.dds.topic_prefix);
    server->start();
    std::fprintf(stderr,
                 "hvac-twin-web: serving %s (DDS domain %d, interface %s, topics %s/*%s%s)\n",
                 server->url().c_str(), participant->domain_id(),
                 participant->interface_name().c_str(), options.dds.topic_prefix.c_str(),
                 options.dds.security ? ", DDS Security on" : "", open ? "" : ", login required");
    if (!options.listen.loopback()) {
      if (open)
        std::fprintf(stderr,
                     "hvac-twin-web: warning: %s is reachable from the network without "
                     "credentials (--basic-auth-file or --token-file)\n",
                     server->url().c_str());
      if (plain)
        std::fprintf(stderr,
                     "hvac-twin-web: warning: %s is plain HTTP on the network: use "
                     "--tls-certificate or a reverse proxy with TLS\n",
                     server->url().c_str());
    }
    std::fflush(stderr);
    const int rc = web::follow(subscriber, dashboard, g_stop);
    server->stop();
    return rc == 0 ? kExitOk : kExitFailure;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hvac-twin-web: %s\n", e.what());
    return kExitFailure;
  }
}

}  // namespace

int main(int argc, char** argv) {
  namespace web = hvac_twin::web;
  web::Options options;
  try {
    options = web::parse_options(argc, argv);
  } catch (const web::UsageError& e) {
    std::fprintf(stderr, "hvac-twin-web: %s\n", e.what());
    return kExitUsage;
  }
  if (options.help) {
    std::fputs(web::usage_text().c_str(), stdout);
    return kExitOk;
  }
  install_signal_handlers();
  return run(options);
}
