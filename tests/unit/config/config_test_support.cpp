#include "config_test_support.hpp"

#include <catch2/catch.hpp>
#include <fstream>
#include <sstream>

#include "plant_models/catalog.hpp"

namespace hvac_twin::config::test {

std::string read_repo_file(const std::string& relative_path) {
  const std::string path = std::string(HVAC_TWIN_SOURCE_DIR) + "/" + relative_path;
  std::ifstream in(path, std::ios::binary);
  INFO("reading " << path);
  REQUIRE(in.good());
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

nlohmann::json demo_json() {
  return nlohmann::json::parse(read_repo_file("config/demo.json"));
}

LoadResult load(std::string_view text) {
  return load_config_text(text, plant::model_schemas());
}

LoadResult load_json(const nlohmann::json& document) {
  return load(document.dump(2));
}

std::string describe(const LoadResult& result) {
  return std::to_string(result.errors.size()) + " error(s):\n" +
         format_errors(result.errors, "test");
}

bool has_error(const LoadResult& result, std::string_view pointer,
               std::initializer_list<std::string_view> words) {
  for (const auto& e : result.errors) {
    if (e.pointer != pointer) continue;
    bool all = true;
    for (const auto w : words)
      all = all && e.message.find(w) != std::string::npos;
    if (all) return true;
  }
  return false;
}

void require_single_error(const LoadResult& result, std::string_view pointer,
                          std::initializer_list<std::string_view> words) {
  INFO(describe(result));
  CHECK_FALSE(result.config.has_value());
  REQUIRE(result.errors.size() == 1);
  CHECK(result.errors[0].pointer == pointer);
  for (const auto w : words) {
    INFO("expected in the message: " << w);
    CHECK(result.errors[0].message.find(w) != std::string::npos);
  }
}

void require_ok(const LoadResult& result) {
  INFO(describe(result));
  REQUIRE(result.errors.empty());
  REQUIRE(result.config.has_value());
}

}  // namespace hvac_twin::config::test
