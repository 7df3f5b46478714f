#include "io/dds/echo/options.hpp"

#include <algorithm>
#include <charconv>
#include <iterator>
#include <string_view>
#include <vector>

#include "io/dds/participant.hpp"

namespace hvac_twin::dds::echo {
namespace {

template <typename T>
T parse_number(std::string_view option, std::string_view text) {
  T value{};
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc{} || end != text.data() + text.size()) {
    throw UsageError(std::string(option) + ": '" + std::string(text) + "' is not a number");
  }
  return value;
}

TopicSet parse_topics(std::string_view list) {
  TopicSet set{false, false, false, false, false, false};
  const auto select = [&set](Topic topic) {
    switch (topic) {
      case Topic::kVirtualSensor:
        set.virtual_sensor = true;
        break;
      case Topic::kObservation:
        set.observation = true;
        break;
      case Topic::kEstimatorHealth:
        set.estimator_health = true;
        break;
      case Topic::kLeakDiagnostic:
        set.leak_diagnostic = true;
        break;
      case Topic::kEstimatorConsistency:
        set.estimator_consistency = true;
        break;
      case Topic::kUnitEstimate:
        set.unit_estimate = true;
        break;
    }
  };
  while (!list.empty()) {
    const std::size_t comma = list.find(',');
    const std::string_view item = list.substr(0, comma);
    const auto* match = std::find_if(std::begin(kAllTopics), std::end(kAllTopics),
                                     [item](Topic t) { return topic_suffix(t) == item; });
    if (match != std::end(kAllTopics)) {
      select(*match);
    } else if (item == "all") {
      set = TopicSet{};
    } else {
      throw UsageError("--topics: unknown topic '" + std::string(item) +
                       "' (virtual_sensor, observation, estimator_health, leak_diagnostic, "
                       "estimator_consistency, unit_estimate, all)");
    }
    list = comma == std::string_view::npos ? std::string_view{} : list.substr(comma + 1);
  }
  if (std::none_of(std::begin(kAllTopics), std::end(kAllTopics),
                   [&set](Topic t) { return set.contains(t); })) {
    throw UsageError("--topics: no topic given");
  }
  return set;
}

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

// All six security options or none.
void finish_security(const config::DdsSecurityConfig& given, int count, Options& options) {
  if (count == 0) return;
  std::string missing;
  for (const auto& option : kSecurityOptions) {
    if (!(given.*option.field).empty()) continue;
    if (!missing.empty()) missing += ", ";
    missing += option.name;
  }
  if (!missing.empty())
    throw UsageError("DDS Security needs all six security options; missing " + missing);
  options.dds.security = given;
}

}  // namespace

Options parse_options(int argc, const char* const* argv) {
  Options options;
  bool peers_given = false;
  config::DdsSecurityConfig security;
  int security_given = 0;
  for (int i = 1; i < argc; ++i) {
    std::string_view arg = argv[i];
    std::string_view value;
    bool has_value = false;
    if (const std::size_t eq = arg.find('='); arg.starts_with("--") && eq != arg.npos) {
      value = arg.substr(eq + 1);
      arg = arg.substr(0, eq);
      has_value = true;
    }
    const auto next = [&]() -> std::string_view {
      if (has_value) return value;
      if (i + 1 >= argc) throw UsageError(std::string(arg) + " needs a value");
      return argv[++i];
    };
    if (arg == "--help" || arg == "-h") {
      options.help = true;
    } else if (arg == "--domain") {
      const int domain = parse_number<int>(arg, next());
      if (domain < 0 || domain > 232) throw UsageError("--domain: must be 0..232");
      options.dds.domain_id = domain;
    } else if (arg == "--interface") {
      options.dds.interface = next();
    } else if (arg == "--peer") {
      if (!peers_given) options.dds.peers.clear();
      peers_given = true;
      options.dds.peers.emplace_back(next());
    } else if (arg == "--multicast") {
      options.dds.allow_multicast = true;
    } else if (arg == "--topic-prefix") {
      options.dds.topic_prefix = next();
    } else if (arg == "--topics") {
      options.topics = parse_topics(next());
    } else if (arg == "--count") {
      const auto count = parse_number<std::uint64_t>(arg, next());
      if (count == 0) throw UsageError("--count: must be at least 1");
      options.count = count;
    } else if (arg == "--duration") {
      const double seconds = parse_number<double>(arg, next());
      if (!(seconds > 0.0 && seconds < 1e9)) throw UsageError("--duration: must be > 0");
      options.duration_s = seconds;
    } else if (arg == "--format") {
      const std::string_view format = next();
      if (format == "json") {
        options.format = Format::kJson;
      } else if (format == "text") {
        options.format = Format::kText;
      } else {
        throw UsageError("--format: must be json or text");
      }
    } else if (const auto* option =
                   std::find_if(std::begin(kSecurityOptions), std::end(kSecurityOptions),
                                [&](const SecurityOption& o) { return o.name == arg; });
               option != std::end(kSecurityOptions)) {
      const std::string_view path = next();
      if (path.empty()) throw UsageError(std::string(arg) + ": empty path");
      security.*option->field = path;
      ++security_given;
    } else {
      throw UsageError("unknown option '" + std::string(arg) + "' (see --help)");
    }
  }
  finish_security(security, security_given, options);
  try {  // the same checks the participant and topics make, reported as usage errors
    (void)topic_name(options.dds.topic_prefix, Topic::kVirtualSensor);
    (void)make_cyclone_config(options.dds);
  } catch (const std::invalid_argument& e) {
    throw UsageError(e.what());
  }
  return options;
}

std::string usage_text() {
  return R"(Usage: hvac-twin-echo [OPTIONS]

Prints every hvac-twin DDS sample (virtual sensors, observations, estimator health, leak
diagnosis, estimator consistency) as one line on stdout, flushed per line. A new subscriber
first receives the latest sample of every key already published.

Options:
  --domain N           DDS domain id, 0..232 (default 0)
  --interface NAME     network interface to use (default lo)
  --peer ADDR          unicast discovery peer; repeatable (default 127.0.0.1)
  --multicast          allow multicast discovery (default: off, unicast to the peers)
  --topic-prefix P     topics are P/virtual_sensor, P/observation, P/estimator_health,
                       P/leak_diagnostic, P/estimator_consistency, P/unit_estimate
                       (default hvac_twin)
  --topics LIST        comma-separated subset of virtual_sensor, observation,
                       estimator_health, leak_diagnostic, estimator_consistency,
                       unit_estimate (default all)
  --count N            exit after N samples
  --duration S         exit after S seconds
  --format json|text   json: one JSON object per sample with a "topic" field (default);
                       text: one aligned human-readable line per sample

DDS Security (all six together, or none; files as for the daemon's dds.security):
  --identity-ca FILE           PEM certificate of the identity CA
  --identity-certificate FILE  PEM certificate of this subscriber, issued by the identity CA
  --private-key FILE           its PEM private key
  --permissions-ca FILE        PEM certificate of the CA that signed the two documents below
  --governance FILE            signed governance document (the daemon's)
  --permissions FILE           signed permissions granting this subscriber's subject
                               subscribe access to the topics
  -h, --help           show this help

Exit status: 0 on success, SIGINT or SIGTERM; 1 on a DDS error; 64 on a usage error.
)";
}

}  // namespace hvac_twin::dds::echo
