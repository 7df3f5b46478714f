#include "daemon/replay/tool_cli.hpp"

#include <cmath>
#include <cstdlib>
#include <exception>

#include "daemon/recording/recording_format.hpp"

namespace hvac_twin::replay {

int parse_tool_args(int argc, char** argv, std::string_view tool,
                    std::span<const ToolOption> options, std::vector<std::string>& positional,
                    void (*usage)(std::FILE*)) {
  const std::string name(tool);
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      usage(stdout);
      return 0;
    }
    if (!arg.starts_with("--")) {
      positional.emplace_back(arg);
      continue;
    }
    const ToolOption* option = nullptr;
    for (const auto& o : options)
      if (o.name == arg) option = &o;
    if (option == nullptr || i + 1 >= argc) {
      std::fprintf(stderr, "%s: unknown or incomplete option \"%s\"\n\n", name.c_str(), argv[i]);
      usage(stderr);
      return kExitUsage;
    }
    const std::string value = argv[++i];
    if (const std::string error = option->set(value); !error.empty()) {
      std::fprintf(stderr, "%s: %s: %s, got \"%s\"\n", name.c_str(), argv[i - 1], error.c_str(),
                   value.c_str());
      return kExitUsage;
    }
  }
  return -1;
}

ToolOption text_option(std::string_view name, std::string& field) {
  return {name, [&field](const std::string& v) {
            field = v;
            return std::string();
          }};
}

int run_tool(std::string_view tool, const std::function<int()>& body) {
  const std::string name(tool);
  try {
    return body();
  } catch (const recording::RecordingError& e) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(), e.what());
    return kExitDataError;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", name.c_str(), e.what());
    return 1;
  }
}

std::string parse_amount(const std::string& text, bool positive, double& out) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(v) || v < 0.0 || (positive && v == 0.0))
    return positive ? "expected a number > 0" : "expected a number >= 0";
  out = v;
  return {};
}

}  // namespace hvac_twin::replay
