#include "io/web/options.hpp"

#include <arpa/inet.h>

namespace hvac_twin::web {
namespace {

using dds::cli::parse_number;

std::size_t parse_count(std::string_view option, std::string_view text, std::size_t min,
                        std::size_t max) {
  const auto n = parse_number<std::size_t>(option, text);
  if (n < min || n > max) {
    throw UsageError(std::string(option) + ": must be " + std::to_string(min) + ".." +
                     std::to_string(max) + "; got " + std::string(text));
  }
  return n;
}

}  // namespace

bool ListenAddress::loopback() const {
  in_addr v4{};
  if (inet_pton(AF_INET, host.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  return host == "::1";
}

std::string ListenAddress::url_host() const {
  return host.find(':') == std::string::npos ? host : "[" + host + "]";
}

ListenAddress parse_listen(std::string_view text) {
  const auto bad = [&](const std::string& why) {
    return UsageError("--listen: '" + std::string(text) + "' " + why);
  };
  ListenAddress a;
  std::string_view port;
  if (text.starts_with('[')) {
    const std::size_t close = text.find(']');
    if (close == std::string_view::npos || text.substr(close + 1, 1) != ":")
      throw bad("is not [IPv6]:PORT");
    a.host = text.substr(1, close - 1);
    port = text.substr(close + 2);
    in6_addr v6{};
    if (inet_pton(AF_INET6, a.host.c_str(), &v6) != 1) throw bad("has no valid IPv6 address");
  } else {
    const std::size_t colon = text.rfind(':');
    if (colon == std::string_view::npos) throw bad("is not HOST:PORT (e.g. 127.0.0.1:8080)");
    a.host = text.substr(0, colon);
    port = text.substr(colon + 1);
    in_addr v4{};
    if (inet_pton(AF_INET, a.host.c_str(), &v4) != 1)
      throw bad(
          "has no valid IPv4 address (a literal like 127.0.0.1, or [::1] for IPv6; no names)");
  }
  int p = -1;
  try {
    p = parse_number<int>("--listen", port);
  } catch (const UsageError&) {
    throw bad("has no valid port");
  }
  if (p < 0 || p > 65535) throw bad("has a port outside 0..65535");
  a.port = p;
  return a;
}

Options parse_options(int argc, const char* const* argv) {
  Options o;
  dds::cli::DdsOptions dds;
  dds::cli::ArgCursor args(argc, argv);
  const auto path = [&](std::string_view option) {
    const std::string_view value = args.value();
    if (value.empty()) throw UsageError(std::string(option) + ": empty path");
    return std::string(value);
  };
  while (args.next()) {
    const std::string_view arg = args.name();
    if (dds.parse(args)) continue;
    if (arg == "--help" || arg == "-h") {
      o.help = true;
    } else if (arg == "--listen") {
      o.listen = parse_listen(args.value());
    } else if (arg == "--basic-auth-file") {
      o.basic_auth_file = path(arg);
    } else if (arg == "--token-file") {
      o.token_file = path(arg);
    } else if (arg == "--tls-certificate") {
      o.tls_certificate = path(arg);
    } else if (arg == "--tls-private-key") {
      o.tls_private_key = path(arg);
    } else if (arg == "--allow-host") {
      const std::string_view host = args.value();
      if (host.empty() || host.find_first_of(":/ \t[]") != std::string_view::npos)
        throw UsageError("--allow-host: '" + std::string(host) + "' is not a host name");
      o.allowed_hosts.emplace_back(host);
    } else if (arg == "--max-clients") {
      o.max_clients = parse_count(arg, args.value(), 1, 1024);
    } else if (arg == "--max-units") {
      o.max_units = parse_count(arg, args.value(), 1, 10000);
    } else if (arg == "--history-samples") {
      o.history_samples = parse_count(arg, args.value(), 16, 1'000'000);
    } else if (arg == "--history-minutes") {
      o.history_minutes = parse_count(arg, args.value(), 1, 31 * 1440);
    } else {
      throw UsageError("unknown option '" + std::string(arg) + "' (see --help)");
    }
  }
  if (o.tls_certificate.has_value() != o.tls_private_key.has_value())
    throw UsageError("TLS needs both --tls-certificate and --tls-private-key");
  o.dds = dds.finish();
  return o;
}

std::string usage_text() {
  return std::string(R"(Usage: hvac-twin-web [OPTIONS]

Serves a live dashboard of the hvac-twin DDS topics over HTTP: a site overview (one tile per
unit: leak state, estimate quality, Modbus, last cycle, stale when its publisher is lost) and a
unit view with live charts (virtual sensors with their 2-sigma band, charge, leak CUSUMs,
innovations, health). Browsers get updates as Server-Sent Events. Read-only.

HTTP:
  --listen HOST:PORT        address to serve on, an IP literal (default 127.0.0.1:8080;
                            [::1]:8080 for IPv6; port 0: any free port)
  --basic-auth-file FILE    require HTTP basic auth: lines user:password
  --token-file FILE         require a bearer token (its first line; >= 16 characters),
                            also accepted as the basic-auth password; FILE may be
                            ${CREDENTIALS_DIRECTORY}/NAME (systemd LoadCredential=)
  --tls-certificate FILE    serve HTTPS with this PEM certificate (chain) ...
  --tls-private-key FILE    ... and its PEM private key
  --allow-host NAME         answer requests for this host name too (repeatable; IP literals
                            and localhost always are; other names are refused, which stops
                            DNS rebinding)
  --max-clients N           open event streams at most (default 32)

History (bounded: per series, the samples and minute buckets below, fixed-size rings):
  --max-units N             units at most (default 64)
  --history-samples N       full-resolution samples per series (default 720: 1 h at 5 s)
  --history-minutes N       one-minute min/mean/max buckets per series (default 1440: 24 h)

DDS:
)") + std::string(dds::cli::dds_usage_text()) +
         R"(
  -h, --help                show this help

Exit status: 0 on SIGINT or SIGTERM; 1 when DDS or the listening socket cannot be set up;
64 on a usage error; 78 when a credentials or TLS file cannot be read or used.
)";
}

}  // namespace hvac_twin::web
