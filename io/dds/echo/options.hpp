// Command-line options of hvac-twin-echo: the shared DDS options (io/dds/cli/options.hpp) and its
// own. Parsing is pure (no I/O) so it can be unit-tested.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "config/config.hpp"
#include "io/dds/cli/options.hpp"
#include "io/dds/subscriber.hpp"

namespace hvac_twin::dds::echo {

enum class Format { kJson, kText };

struct Options {
  config::DdsConfig dds;               // domain, interface, peers, topic prefix, security
  TopicSet topics;                     // --topics
  std::optional<std::uint64_t> count;  // --count: exit after this many samples
  std::optional<double> duration_s;    // --duration: exit after this many seconds [s, wall]
  Format format = Format::kJson;       // --format
  bool help = false;                   // --help
};

// A command-line mistake; what() is a one-line message for stderr (the shared DDS options' type).
using UsageError = cli::UsageError;

// Parses argv[1..argc-1]. Throws UsageError. Allocates; start-up only.
Options parse_options(int argc, const char* const* argv);

// The --help text.
std::string usage_text();

}  // namespace hvac_twin::dds::echo
