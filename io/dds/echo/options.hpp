// Command-line options of hvac-twin-echo. Parsing is pure (no I/O) so it can be unit-tested.
#pragma once

#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>

#include "config/config.hpp"
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

// A command-line mistake; what() is a one-line message for stderr.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Parses argv[1..argc-1]. Throws UsageError. Allocates; start-up only.
Options parse_options(int argc, const char* const* argv);

// The --help text.
std::string usage_text();

}  // namespace hvac_twin::dds::echo
