#include "io/dds/cli/options.hpp"

#include <algorithm>
#include <filesystem>
#include <iterator>

#include "io/dds/participant.hpp"
#include "io/dds/types.hpp"

namespace hvac_twin::dds::cli {
namespace {

// The DDS Security files: each option fills one field of config::DdsSecurityConfig.
struct SecurityOption {
  std::string_view name;
  std::string config::DdsSecurityConfig::*field;
};
constexpr SecurityOption kSecurityOptions[] = {
    {"--identity-ca", &config::DdsSecurityConfig::identity_ca},
    {"--identity-certificate", &config::DdsSecurityConfig::identity_certificate},
    {"--private-key", &config::DdsSecurityConfig::private_key},
    {"--permissions-ca", &config::DdsSecurityConfig::permissions_ca},
    {"--governance", &config::DdsSecurityConfig::governance},
    {"--permissions", &config::DdsSecurityConfig::permissions},
};

}  // namespace

bool ArgCursor::next() {
  if (++i_ >= argc_) return false;
  name_ = argv_[i_];
  has_inline_value_ = false;
  if (const std::size_t eq = name_.find('='); name_.starts_with("--") && eq != name_.npos) {
    inline_value_ = name_.substr(eq + 1);
    name_ = name_.substr(0, eq);
    has_inline_value_ = true;
  }
  return true;
}

std::string_view ArgCursor::value() {
  if (has_inline_value_) return inline_value_;
  if (i_ + 1 >= argc_) throw UsageError(std::string(name_) + " needs a value");
  return argv_[++i_];
}

bool DdsOptions::parse(ArgCursor& args) {
  const std::string_view arg = args.name();
  if (arg == "--domain") {
    const int domain = parse_number<int>(arg, args.value());
    if (domain < 0 || domain > 232) throw UsageError("--domain: must be 0..232");
    dds_.domain_id = domain;
  } else if (arg == "--interface") {
    dds_.interface = args.value();
  } else if (arg == "--peer") {
    if (!peers_given_) dds_.peers.clear();
    peers_given_ = true;
    dds_.peers.emplace_back(args.value());
  } else if (arg == "--multicast") {
    dds_.allow_multicast = true;
  } else if (arg == "--topic-prefix") {
    dds_.topic_prefix = args.value();
  } else if (const auto* option =
                 std::find_if(std::begin(kSecurityOptions), std::end(kSecurityOptions),
                              [&](const SecurityOption& o) { return o.name == arg; });
             option != std::end(kSecurityOptions)) {
    const std::string_view path = args.value();
    if (path.empty()) throw UsageError(std::string(arg) + ": empty path");
    security_.*option->field = path;
    ++security_given_;
  } else {
    return false;
  }
  return true;
}

config::DdsConfig DdsOptions::finish() const {
  config::DdsConfig dds = dds_;
  if (security_given_ > 0) {  // all six or none
    std::string missing;
    for (const auto& option : kSecurityOptions) {
      if (!(security_.*option.field).empty()) continue;
      if (!missing.empty()) missing += ", ";
      missing += option.name;
    }
    if (!missing.empty())
      throw UsageError("DDS Security needs all six security options; missing " + missing);
    dds.security = security_;
  }
  try {  // the same checks the participant and topics make, reported as usage errors
    (void)topic_name(dds.topic_prefix, Topic::kVirtualSensor);
    (void)make_cyclone_config(dds);
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  return dds;
}

void make_security_paths_absolute(config::DdsConfig& dds) {
  if (!dds.security) return;
  auto& s = *dds.security;
  for (std::string* path : {&s.identity_ca, &s.identity_certificate, &s.private_key,
                            &s.permissions_ca, &s.governance, &s.permissions})
    if (!path->starts_with('/') && !path->starts_with("${"))
      *path = std::filesystem::absolute(*path).string();
}

std::string_view dds_usage_text() {
  return R"(  --domain N           DDS domain id, 0..232 (default 0)
  --interface NAME     network interface to use (default lo)
  --peer ADDR          unicast discovery peer; repeatable (default 127.0.0.1)
  --multicast          allow multicast discovery (default: off, unicast to the peers)
  --topic-prefix P     topics are P/virtual_sensor, P/observation, P/estimator_health,
                       P/leak_diagnostic, P/estimator_consistency, P/unit_estimate
                       (default hvac_twin)

DDS Security (all six together, or none; files as for the daemon's dds.security):
  --identity-ca FILE           PEM certificate of the identity CA
  --identity-certificate FILE  PEM certificate of this subscriber, issued by the identity CA
  --private-key FILE           its PEM private key
  --permissions-ca FILE        PEM certificate of the CA that signed the two documents below
  --governance FILE            signed governance document (the daemon's)
  --permissions FILE           signed permissions granting this subscriber's subject
                               subscribe access to the topics
)";
}

}  // namespace hvac_twin::dds::cli
