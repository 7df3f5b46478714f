// Helpers for the configuration tests: the demo configuration as an editable JSON value, loading
// against the real model catalog, and assertions on the reported errors.
#pragma once

#include <initializer_list>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "config/load.hpp"

namespace hvac_twin::config::test {

// A file of the repository, e.g. "config/demo.json".
std::string read_repo_file(const std::string& relative_path);

// config/demo.json, parsed (edit it, then load(json)).
nlohmann::json demo_json();

// Loads against plant::model_schemas(): text as is, or a JSON value (written with sorted keys).
LoadResult load(std::string_view text);
LoadResult load_json(const nlohmann::json& document);

// All errors, formatted, for failure messages.
std::string describe(const LoadResult& result);

// True when some error is at `pointer` and its message contains every one of `words`.
bool has_error(const LoadResult& result, std::string_view pointer,
               std::initializer_list<std::string_view> words);

// Requires no config and exactly one error, at `pointer`, whose message contains every word.
void require_single_error(const LoadResult& result, std::string_view pointer,
                          std::initializer_list<std::string_view> words);

// Requires a config and no errors.
void require_ok(const LoadResult& result);

}  // namespace hvac_twin::config::test
