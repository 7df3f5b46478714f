// Readers for the Modbus device, DDS (with DDS Security) and runtime sections.
#include <algorithm>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "config/detail/limits.hpp"
#include "config/detail/sections.hpp"
#include "config/enum_names.hpp"

namespace hvac_twin::config::detail {
namespace {

bool is_digit(char c) {
  return c >= '0' && c <= '9';
}
bool is_alnum(char c) {
  return is_digit(c) || (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z');
}
// Characters of a network interface name or address as Cyclone DDS takes it.
bool is_interface_char(char c) {
  return is_identifier_char(c) || c == '-' || c == '.' || c == ':';
}
// Characters of a Cyclone DDS peer: host name, IPv4, [IPv6], optional :port.
bool is_peer_char(char c) {
  return is_interface_char(c) || c == '[' || c == ']';
}

// Reports `message` at the member `key` when given, else at the object (its default is wrong).
void report_field(ObjectReader& r, std::string_view key, const std::string& message) {
  const Ref field = r.get(key);
  if (field.present())
    r.errors().add(*field.node, field.pointer, message);
  else if (r.ok())
    r.errors().add(*r.ref().node, r.ref().pointer, message);
}

std::string seconds(double v) {
  return format_number(v) + " s";
}

constexpr std::string_view kCredentialsPrefix = "${CREDENTIALS_DIRECTORY}/";

// Why `path` is not a DDS Security file path (DdsSecurityConfig), or "" when it is one.
std::string security_path_problem(std::string_view path) {
  if (path.size() > kMaxPathLength) return "longer than 4096 characters";
  std::string_view rest = path;
  if (rest.starts_with(kCredentialsPrefix)) {
    rest.remove_prefix(kCredentialsPrefix.size());
    if (rest.empty() || rest.find('/') != std::string_view::npos)
      return "a credential is one file name after ${CREDENTIALS_DIRECTORY}/";
  } else if (!rest.starts_with('/')) {
    return "not an absolute path";
  }
  for (const char c : rest) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) return "contains a control character";
    if (std::string_view("<>&$\\").find(c) != std::string_view::npos)
      return std::string("contains '") + c + "'";
  }
  return {};
}

std::optional<DdsSecurityConfig> read_security(const Ref& ref, Errors& errors) {
  if (!ref.present()) return std::nullopt;
  DdsSecurityConfig s;
  bool ok = true;
  ObjectReader r(ref, errors);
  const auto path = [&](std::string_view key, std::string& out) {
    const Ref v = r.require(key);
    if (!v.present()) {
      ok = false;
      return;
    }
    const auto text = read_string(v, errors);
    if (!text) {
      ok = false;
      return;
    }
    if (const std::string problem = security_path_problem(*text); !problem.empty()) {
      errors.add(*v.node, v.pointer,
                 "expected an absolute file path or \"${CREDENTIALS_DIRECTORY}/<name>\" without "
                 "control characters or any of < > & $ \\; got " +
                     describe_value(*v.node) + " (" + problem + ")");
      ok = false;
      return;
    }
    out = *text;
  };
  path("identity_ca", s.identity_ca);
  path("identity_certificate", s.identity_certificate);
  path("private_key", s.private_key);
  path("permissions_ca", s.permissions_ca);
  path("governance", s.governance);
  path("permissions", s.permissions);
  r.finish();
  if (!r.ok() || !ok) return std::nullopt;
  return s;
}

}  // namespace

bool is_ipv4_address(std::string_view s) {
  int parts = 0;
  std::size_t i = 0;
  while (true) {
    std::size_t digits = 0;
    int value = 0;
    while (i < s.size() && is_digit(s[i]) && digits < 4) {
      value = value * 10 + (s[i] - '0');
      ++digits;
      ++i;
    }
    if (digits == 0 || digits > 3 || value > 255) return false;
    ++parts;
    if (i == s.size()) return parts == 4;
    if (s[i] != '.' || parts == 4) return false;
    ++i;
  }
}

bool is_host_name(std::string_view s) {
  if (s.empty() || s.size() > 253) return false;
  if (std::all_of(s.begin(), s.end(), [](char c) { return is_digit(c) || c == '.'; }))
    return is_ipv4_address(s);
  std::size_t start = 0;
  while (start <= s.size()) {
    const std::size_t end = std::min(s.find('.', start), s.size());
    const std::string_view label = s.substr(start, end - start);
    if (label.empty() || label.size() > 63 || label.front() == '-' || label.back() == '-')
      return false;
    if (!std::all_of(label.begin(), label.end(), [](char c) { return is_alnum(c) || c == '-'; }))
      return false;
    start = end + 1;
  }
  return true;
}

ModbusSection read_modbus(const Ref& ref, Errors& errors) {
  ModbusSection out;
  ModbusDeviceConfig& m = out.config;
  ObjectReader r(ref, errors);
  if (const Ref host = r.get("host"); host.present()) {
    const auto v = read_string(host, errors);
    if (v && is_host_name(*v))
      m.host = *v;
    else if (v)
      errors.add(*host.node, host.pointer,
                 "expected an IPv4 address or a host name; got " + describe_value(*host.node));
  }
  r.integer("port", m.port, 1, 65535);
  r.integer("unit_id", m.unit_id, 0, 255);
  const bool poll_ok = r.number("poll_period_s", m.poll_period_s,
                                closed(kMinPollPeriodS, kMaxPollPeriodS), false, "s");
  const bool response_ok =
      r.number("response_timeout_s", m.response_timeout_s, positive(kMaxTimeoutS), false, "s");
  const bool byte_ok =
      r.number("byte_timeout_s", m.byte_timeout_s, positive(kMaxTimeoutS), false, "s");
  const bool initial_ok =
      r.number("backoff_initial_s", m.backoff_initial_s, positive(kMaxBackoffS), false, "s");
  const bool max_ok =
      r.number("backoff_max_s", m.backoff_max_s, positive(kMaxBackoffS), false, "s");
  r.integer("max_registers_per_request", m.max_registers_per_request, 1, 125);
  out.max_registers = r.get("max_registers_per_request");
  r.finish();
  if (poll_ok) out.poll_period_s = m.poll_period_s;

  // Cross-field rules (reliability.md), checked only between valid values.
  if (poll_ok && response_ok && !(m.response_timeout_s < m.poll_period_s / 2.0))
    report_field(r, "response_timeout_s",
                 "response_timeout_s (" + seconds(m.response_timeout_s) +
                     ") must be below half of poll_period_s (" + seconds(m.poll_period_s) +
                     "), so that a timed-out request and the reconnect fit in one poll period");
  if (response_ok && byte_ok && m.byte_timeout_s > m.response_timeout_s)
    report_field(r, "byte_timeout_s",
                 "byte_timeout_s (" + seconds(m.byte_timeout_s) +
                     ") must not exceed response_timeout_s (" + seconds(m.response_timeout_s) +
                     ")");
  if (initial_ok && max_ok && m.backoff_initial_s > m.backoff_max_s)
    report_field(r, "backoff_initial_s",
                 "backoff_initial_s (" + seconds(m.backoff_initial_s) +
                     ") must not exceed backoff_max_s (" + seconds(m.backoff_max_s) + ")");
  return out;
}

DdsConfig read_dds(const Ref& ref, Errors& errors) {
  DdsConfig d;
  ObjectReader r(ref, errors);
  r.integer("domain_id", d.domain_id, 0, 232);
  if (const Ref v = r.get("interface"); v.present()) {
    if (auto s = read_token(v, errors, is_interface_char, "[A-Za-z0-9_.:-]", kMaxNameLength))
      d.interface = *s;
  }
  const bool multicast_ok = r.boolean("allow_multicast", d.allow_multicast);
  const Ref peers = r.get("peers");
  bool peers_ok = true;
  if (peers.present()) {
    if (!peers.node->is_array()) {
      errors.add(
          *peers.node, peers.pointer,
          "expected an array of host names or addresses; got " + describe_value(*peers.node));
      peers_ok = false;
    } else {
      d.peers.clear();
      for (std::size_t i = 0; i < peers.node->elements.size(); ++i) {
        const auto s = read_token(peers.at(i), errors, is_peer_char, "[A-Za-z0-9_.:[]-]", 255);
        if (s)
          d.peers.push_back(*s);
        else
          peers_ok = false;
      }
    }
  }
  if (const Ref v = r.get("topic_prefix"); v.present()) {
    if (auto s = read_token(v, errors, is_identifier_char, "[A-Za-z0-9_]", kMaxNameLength))
      d.topic_prefix = *s;
  }
  d.security = read_security(r.get("security"), errors);
  r.finish();
  if (multicast_ok && peers_ok && !d.allow_multicast && d.peers.empty())
    report_field(r, "peers",
                 "expected at least one peer when allow_multicast is false (nothing would be "
                 "discovered)");
  return d;
}

RuntimeSection read_runtime(const Ref& ref, Errors& errors) {
  RuntimeSection out;
  RuntimeConfig& c = out.config;
  ObjectReader r(ref, errors);
  if (r.number("time_scale", c.time_scale, closed(kMinTimeScale, kMaxTimeScale)))
    out.time_scale = c.time_scale;
  if (r.number("hang_timeout_s", c.hang_timeout_s, positive(kMaxHangTimeoutS), false, "s"))
    out.hang_timeout_s = c.hang_timeout_s;
  r.boolean("hang_exit", c.hang_exit);
  r.integer("overruns_before_watchdog_stop", c.overruns_before_watchdog_stop, 1, 1000);
  r.integer("recording_budget_mib", c.recording_budget_mib, 0, kMaxRecordingBudgetMib);
  if (const Ref v = r.get("log_level"); v.present()) {
    if (const auto i = read_choice(v, errors, kLogLevelNames))
      c.log_level = std::string(kLogLevelNames[*i]);
  }
  r.finish();
  return out;
}

}  // namespace hvac_twin::config::detail
