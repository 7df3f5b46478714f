#include "io/dds/echo/options.hpp"

#include <algorithm>
#include <iterator>
#include <string_view>

#include "io/dds/cli/options.hpp"

namespace hvac_twin::dds::echo {
namespace {

using cli::parse_number;

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

}  // namespace

Options parse_options(int argc, const char* const* argv) {
  Options options;
  cli::DdsOptions dds;
  cli::ArgCursor args(argc, argv);
  while (args.next()) {
    const std::string_view arg = args.name();
    if (dds.parse(args)) continue;
    if (arg == "--help" || arg == "-h") {
      options.help = true;
    } else if (arg == "--topics") {
      options.topics = parse_topics(args.value());
    } else if (arg == "--count") {
      const auto count = parse_number<std::uint64_t>(arg, args.value());
      if (count == 0) throw UsageError("--count: must be at least 1");
      options.count = count;
    } else if (arg == "--duration") {
      const double seconds = parse_number<double>(arg, args.value());
      if (!(seconds > 0.0 && seconds < 1e9)) throw UsageError("--duration: must be > 0");
      options.duration_s = seconds;
    } else if (arg == "--format") {
      const std::string_view format = args.value();
      if (format == "json") {
        options.format = Format::kJson;
      } else if (format == "text") {
        options.format = Format::kText;
      } else {
        throw UsageError("--format: must be json or text");
      }
    } else {
      throw UsageError("unknown option '" + std::string(arg) + "' (see --help)");
    }
  }
  options.dds = dds.finish();
  return options;
}

std::string usage_text() {
  return std::string(R"(Usage: hvac-twin-echo [OPTIONS]

Prints every hvac-twin DDS sample (virtual sensors, observations, estimator health, leak
diagnosis, estimator consistency) as one line on stdout, flushed per line. A new subscriber
first receives the latest sample of every key already published.

Options:
)") + std::string(cli::dds_usage_text()) +
         R"(
Output:
  --topics LIST        comma-separated subset of virtual_sensor, observation,
                       estimator_health, leak_diagnostic, estimator_consistency,
                       unit_estimate (default all)
  --count N            exit after N samples
  --duration S         exit after S seconds
  --format json|text   json: one JSON object per sample with a "topic" field (default);
                       text: one aligned human-readable line per sample
  -h, --help           show this help

Exit status: 0 on success, SIGINT or SIGTERM; 1 on a DDS error; 64 on a usage error.
)";
}

}  // namespace hvac_twin::dds::echo
