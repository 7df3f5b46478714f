// Command-line options of hvac-twin-web: the DDS options every subscriber tool shares
// (io/dds/cli/options.hpp: domain, interface, peers, multicast, topic prefix, DDS Security) and
// its own (listen address, authentication, TLS, limits). Parsing is pure (no I/O) so it can be
// unit-tested; the credential and TLS files are read later, at start-up (auth.hpp, server.hpp).
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "config/config.hpp"
#include "io/dds/cli/options.hpp"

namespace hvac_twin::web {

using UsageError = dds::cli::UsageError;

struct ListenAddress {
  std::string host = "127.0.0.1";  // an IPv4 or IPv6 literal, never a name
  int port = 8080;                 // 0: any free port (printed at start-up)
  bool loopback() const;           // 127.0.0.0/8 or ::1
  std::string url_host() const;    // "127.0.0.1", "[::1]"
};

struct Options {
  config::DdsConfig dds;                       // as hvac-twin-echo's
  ListenAddress listen;                        // --listen HOST:PORT
  std::optional<std::string> basic_auth_file;  // --basic-auth-file FILE
  std::optional<std::string> token_file;       // --token-file FILE
  std::optional<std::string> tls_certificate;  // --tls-certificate FILE (PEM, with the chain)
  std::optional<std::string> tls_private_key;  // --tls-private-key FILE (PEM)
  std::vector<std::string> allowed_hosts;      // --allow-host NAME (repeatable)
  std::size_t max_clients = 32;                // --max-clients N: open event streams
  std::size_t max_units = 64;                  // --max-units N
  std::size_t history_samples = 720;           // --history-samples N: full resolution per series
  std::size_t history_minutes = 1440;          // --history-minutes N: minute buckets per series
  bool help = false;
};

// "127.0.0.1:8080", "[::1]:8080", "0.0.0.0:80". Throws UsageError naming --listen and the text.
ListenAddress parse_listen(std::string_view text);

// Parses argv[1..argc-1]. Throws UsageError. Allocates; start-up only.
Options parse_options(int argc, const char* const* argv);

// The --help text.
std::string usage_text();

}  // namespace hvac_twin::web
