// The command-line options every hvac-twin DDS subscriber tool shares (hvac-twin-echo,
// hvac-twin-web): the domain, interface pinning, discovery peers, multicast, the topic prefix and
// the six DDS Security files, parsed into a config::DdsConfig with the same checks the
// participant makes, so that a mistake is a usage error (exit 64) at start-up rather than a DDS
// failure later. Also the argv walk both tools use ("--name value" and "--name=value").
//
// Pure (no I/O) so it can be unit-tested. Allocates; start-up only; any thread.
#pragma once

#include <charconv>
#include <stdexcept>
#include <string>
#include <string_view>

#include "config/config.hpp"

namespace hvac_twin::dds::cli {

// A command-line mistake; what() is a one-line message for stderr naming the option.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Walks argv[1..argc-1] one option at a time. The arrays are borrowed, not copied.
class ArgCursor {
 public:
  ArgCursor(int argc, const char* const* argv) : argc_(argc), argv_(argv) {}
  // Moves to the next argument; false when there is none.
  bool next();
  // The current option's name ("--domain" of "--domain=7" too).
  std::string_view name() const { return name_; }
  // Its value: after '=', else the next argument. Throws UsageError "--x needs a value".
  std::string_view value();

 private:
  int argc_;
  const char* const* argv_;
  int i_ = 0;
  std::string_view name_;
  std::string_view inline_value_;
  bool has_inline_value_ = false;
};

// `text` as a T, the whole of it. Throws UsageError "<option>: 'text' is not a number".
template <typename T>
T parse_number(std::string_view option, std::string_view text) {
  T value{};
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc{} || end != text.data() + text.size() || text.empty()) {
    throw UsageError(std::string(option) + ": '" + std::string(text) + "' is not a number");
  }
  return value;
}

// Collects the DDS options of one command line.
class DdsOptions {
 public:
  // If the cursor's option is a DDS option, consumes its value and returns true; false for any
  // other option (left to the tool). Throws UsageError for a bad value.
  bool parse(ArgCursor& args);
  // The configuration: security all six or none, the prefix and the Cyclone configuration
  // checked. Throws UsageError.
  config::DdsConfig finish() const;

 private:
  config::DdsConfig dds_;
  bool peers_given_ = false;
  config::DdsSecurityConfig security_;
  int security_given_ = 0;
};

// Makes the relative DDS Security paths of `dds` absolute against the working directory (Cyclone
// reads them as given, from wherever it runs); "${CREDENTIALS_DIRECTORY}/..." stays for the
// participant to resolve. Reads the working directory: call once at start-up.
void make_security_paths_absolute(config::DdsConfig& dds);

// The --help lines of the DDS options, "  --domain N ..." through "--permissions FILE ...".
std::string_view dds_usage_text();

}  // namespace hvac_twin::dds::cli
