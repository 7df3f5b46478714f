// Properties that hold for any input: loading never throws (but bad_alloc), reports errors iff it
// returns no config, and every error's pointer names a value of the document.
#include <catch2/catch.hpp>
#include <random>
#include <string>
#include <vector>

#include "config_test_support.hpp"

namespace hvac_twin::config {
namespace {

using nlohmann::json;
using test::demo_json;
using test::load;
using test::load_json;
using test::read_repo_file;

void collect_pointers(const json& j, const json::json_pointer& at,
                      std::vector<json::json_pointer>& out) {
  out.push_back(at);
  if (j.is_object()) {
    for (const auto& [key, value] : j.items())
      collect_pointers(value, at / key, out);
  } else if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i)
      collect_pointers(j[i], at / i, out);
  }
}

void check_result_shape(const LoadResult& r) {
  CHECK(r.config.has_value() == r.errors.empty());
  for (const auto& e : r.errors) {
    CHECK_FALSE(e.message.empty());
    CHECK(e.message.find('\n') == std::string::npos);
  }
}

TEST_CASE("random edits of the demo: no throw, and every pointer resolves", "[config]") {
  const json demo = demo_json();
  const std::vector<json> pool{0,
                               -1,
                               1.5,
                               3000000000LL,
                               -3000000000LL,
                               1e308,
                               "",
                               "x",
                               "NaN",
                               nullptr,
                               true,
                               json::array(),
                               json::object(),
                               json::array({1, 2}),
                               "zone_air_temperature",
                               "input",
                               "float32",
                               65535};
  std::mt19937 rng(20240601);
  int rejected = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    json j = demo;
    const int edits = 1 + static_cast<int>(rng() % 3);
    for (int e = 0; e < edits; ++e) {
      std::vector<json::json_pointer> pointers;
      collect_pointers(j, json::json_pointer(), pointers);
      const json::json_pointer ptr = pointers[rng() % pointers.size()];
      if (ptr.empty()) continue;
      switch (rng() % 3) {
        case 0:
          j[ptr] = pool[rng() % pool.size()];
          break;
        case 1: {  // remove it from its parent
          json& parent = j[ptr.parent_pointer()];
          if (parent.is_object())
            parent.erase(ptr.back());
          else if (parent.is_array())
            parent.erase(static_cast<std::size_t>(std::stoul(ptr.back())));
          break;
        }
        default:
          if (j[ptr].is_object()) j[ptr]["unexpected/key~"] = 1;
          break;
      }
    }
    INFO("document: " << j.dump());
    LoadResult r;
    REQUIRE_NOTHROW(r = load_json(j));
    check_result_shape(r);
    rejected += r.config ? 0 : 1;
    for (const auto& e : r.errors) {
      INFO("pointer: " << e.pointer << " message: " << e.message);
      CHECK(j.contains(json::json_pointer(e.pointer)));
    }
  }
  CHECK(rejected > 2000);  // the edits mostly break the document: the test exercises errors
}

TEST_CASE("every truncation of the demo text fails cleanly", "[config]") {
  const std::string text = read_repo_file("config/demo.json");
  for (std::size_t n = 0; n + 1 < text.size(); ++n) {
    INFO("first " << n << " bytes");
    LoadResult r;
    REQUIRE_NOTHROW(r = load(std::string_view(text).substr(0, n)));
    check_result_shape(r);
    REQUIRE(r.errors.size() == 1);
    CHECK(r.errors[0].pointer.empty());
  }
}

TEST_CASE("random bytes in the demo text: no throw", "[config]") {
  const std::string text = read_repo_file("config/demo.json");
  std::mt19937 rng(7);
  for (int trial = 0; trial < 2000; ++trial) {
    std::string t = text;
    for (int k = 0; k < 3; ++k)
      t[rng() % t.size()] = static_cast<char>(rng() % 256);
    LoadResult r;
    REQUIRE_NOTHROW(r = load(t));
    check_result_shape(r);
  }
}

}  // namespace
}  // namespace hvac_twin::config
