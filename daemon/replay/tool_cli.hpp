// The command line of the offline tools (hvac-twin-replay, hvac-twin-calibrate): "--name VALUE"
// options, -h/--help, and positional input files; and the exit statuses they share.
#pragma once

#include <cstdio>
#include <functional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace hvac_twin::replay {

inline constexpr int kExitUsage = 2;
inline constexpr int kExitDataError = 65;  // sysexits EX_DATAERR: bad input data
inline constexpr int kExitNoInput = 66;    // EX_NOINPUT

struct ToolOption {
  std::string_view name;  // "--out"
  // Takes the option's value; returns "" or what was wrong with it ("expected seconds > 0").
  std::function<std::string(const std::string&)> set;
};

// Parses argv. Returns -1 to go on, 0 after printing the usage for --help, or kExitUsage after
// saying on stderr what was wrong (an unknown option, a missing or refused value).
int parse_tool_args(int argc, char** argv, std::string_view tool,
                    std::span<const ToolOption> options, std::vector<std::string>& positional,
                    void (*usage)(std::FILE*));

// An option that stores its value as given.
ToolOption text_option(std::string_view name, std::string& field);

// Runs the tool's body: its exit status, or kExitDataError after a recording::RecordingError
// (bad input data) and 1 after any other exception, each said on stderr.
int run_tool(std::string_view tool, const std::function<int()>& body);

// A number option's value: finite and > 0 (`positive`) or >= 0; "" or what was expected.
std::string parse_amount(const std::string& text, bool positive, double& out);

}  // namespace hvac_twin::replay
