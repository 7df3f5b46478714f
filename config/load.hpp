// Loading and validating the configuration. Start-up only (allocates, may throw std::bad_alloc;
// every other problem is reported as a ConfigError, never thrown).
#pragma once

#include <cstddef>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "config/config.hpp"
#include "plant_models/core/model_info.hpp"

namespace hvac_twin::config {

// The model types configuration may name; the runtime passes plant::model_schemas().
using ModelCatalog = std::vector<plant::ModelSchema>;

inline constexpr int kExitConfigError = 78;  // EX_CONFIG from sysexits.h

// A hostile file can hold millions of errors (one per unknown key): the loader keeps the first
// kMaxKeptErrors in document order and counts the rest; format_errors prints kMaxShownErrors.
inline constexpr std::size_t kMaxKeptErrors = 10000;
inline constexpr std::size_t kMaxShownErrors = 100;

struct ConfigError {
  std::string pointer;  // RFC 6901 JSON pointer of the offending value ("" = the whole document)
  std::string message;  // what was wrong and what was expected, e.g.
                        // "expected one of \"holding\", \"input\"; got \"coil\""
};

struct LoadResult {
  std::optional<Config> config;     // set only when errors is empty
  std::vector<ConfigError> errors;  // the errors found, in document order, at most
                                    // kMaxKeptErrors of them (a JSON syntax error stops parsing
                                    // and is then the only one)
  std::size_t more_errors = 0;      // errors found beyond those kept in `errors`

  [[nodiscard]] std::size_t error_count() const { return errors.size() + more_errors; }
};

// Parses and validates a JSON document (strict RFC 8259; unknown and duplicate keys are errors).
// Model types, parameter names and ranges, and the signal/state names that points and estimator
// maps refer to are checked against `models`. The rules are in config.hpp and config/README.md.
// Any thread; pure (no I/O).
LoadResult load_config_text(std::string_view json_text, const ModelCatalog& models);

// Reads `path` and calls load_config_text. An unreadable file is one error with pointer "".
LoadResult load_config_file(const std::string& path, const ModelCatalog& models);

// One line per error for the first `limit` errors: "<source>: <pointer>: <message>" (pointer "/"
// style, "" shown as "(root)"), each ending in '\n'; control characters are written as \u00XX so
// a line stays one line. The caller says how many were not shown.
std::string format_errors(const std::vector<ConfigError>& errors, std::string_view source,
                          std::size_t limit = kMaxShownErrors);

}  // namespace hvac_twin::config
