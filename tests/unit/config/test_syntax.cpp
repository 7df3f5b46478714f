// Document-level errors: JSON syntax, empty and wrong-typed documents, duplicate and unknown
// keys, numbers nlohmann-json would mishandle (wrapping integers, overflow, NaN), pointer escapes.
#include <algorithm>
#include <catch2/catch.hpp>
#include <string>

#include "config_test_support.hpp"

namespace hvac_twin::config {
namespace {

using test::demo_json;
using test::load;
using test::load_json;
using test::read_repo_file;
using test::require_single_error;

// The demo text with the first occurrence of `from` replaced by `to`.
std::string demo_with(std::string_view from, std::string_view to) {
  std::string text = read_repo_file("config/demo.json");
  const auto at = text.find(from);
  REQUIRE(at != std::string::npos);
  text.replace(at, from.size(), to);
  return text;
}

TEST_CASE("a JSON syntax error reports line and column", "[config]") {
  const LoadResult r = load("{\n  \"site_id\": \"x\",\n  \"units\": [,]\n}");
  require_single_error(r, "", {"invalid JSON", "line 3, column 13"});

  // A missing comma in the demo (line 9): the error points at the end of the next key.
  const LoadResult demo = load(demo_with("\"port\": 15020,", "\"port\": 15020"));
  require_single_error(demo, "", {"invalid JSON", "line 10, column 17", "expected '}'"});
}

TEST_CASE("trailing commas, comments and trailing garbage are syntax errors", "[config]") {
  require_single_error(load(R"({"site_id": "x",})"), "", {"invalid JSON", "line 1, column 17"});
  require_single_error(load("// comment\n{}"), "", {"invalid JSON", "line 1, column 1"});
  require_single_error(load("{} {}"), "", {"invalid JSON", "line 1, column 4"});
  require_single_error(load("{\"a\": \"\xff\"}"), "", {"invalid JSON"});  // not UTF-8
}

TEST_CASE("an empty document is one error at the root", "[config]") {
  require_single_error(load(""), "", {"empty", "expected a JSON object"});
  require_single_error(load(" \n\t\n"), "", {"empty", "expected a JSON object"});
}

TEST_CASE("a document that is not an object is one error at the root", "[config]") {
  require_single_error(load("[]"), "", {"expected an object; got an array"});
  require_single_error(load("\"demo\""), "", {"expected an object; got \"demo\""});
  require_single_error(load("42"), "", {"expected an object; got 42"});
  require_single_error(load("null"), "", {"expected an object; got null"});
}

TEST_CASE("missing top-level fields are reported at the root", "[config]") {
  const LoadResult r = load("{}");
  INFO(test::describe(r));
  REQUIRE(r.errors.size() == 2);
  CHECK(test::has_error(r, "", {"missing required field \"site_id\""}));
  CHECK(test::has_error(r, "", {"missing required field \"units\""}));
}

TEST_CASE("a duplicate key is an error at the second occurrence", "[config]") {
  require_single_error(load(demo_with("\"port\": 15020,", "\"port\": 15020, \"port\": 15021,")),
                       "/units/0/modbus/port", {"duplicate key \"port\""});
  require_single_error(load(demo_with("\"site_id\": \"demo-site\",",
                                      "\"site_id\": \"demo-site\", \"site_id\": \"other\",")),
                       "/site_id", {"duplicate key \"site_id\""});
  // The first value is the one checked: a valid first and an invalid second give one error.
  require_single_error(load(demo_with("\"Q_int\": 1.0", "\"Q_int\": 1.0, \"Q_int\": -1")),
                       "/units/0/estimator/process_noise/Q_int", {"duplicate key \"Q_int\""});
}

TEST_CASE("an unknown key is an error, with a suggestion for near misses", "[config]") {
  require_single_error(load(demo_with("\"port\": 15020,", "\"port\": 15020, \"prot\": 1,")),
                       "/units/0/modbus/prot", {"unknown key \"prot\"", "did you mean \"port\"?"});
  require_single_error(
      load(demo_with("\"runtime\": {", "\"runtime\": {\"colour\": \"red\",")), "/runtime/colour",
      {"unknown key \"colour\"", "expected one of", "\"time_scale\"", "\"log_level\""});
  require_single_error(load(demo_with("\"site_id\"", "\"siteid\": \"x\", \"site_id\"")), "/siteid",
                       {"unknown key \"siteid\"", "did you mean \"site_id\"?"});
}

TEST_CASE("keys with ~ and / are escaped in pointers (RFC 6901)", "[config]") {
  require_single_error(load(demo_with("\"site_id\"", "\"a/b~c\": 1, \"site_id\"")), "/a~1b~0c",
                       {"unknown key \"a/b~c\""});
  require_single_error(load(demo_with("\"Q_int\": 1.0", "\"Q_int\": 1.0, \"x/y\": 1")),
                       "/units/0/estimator/process_noise/x~1y", {"unknown state \"x/y\""});
}

TEST_CASE("integers are checked for range before conversion", "[config]") {
  auto j = demo_json();
  j["units"][0]["modbus"]["port"] = 3000000000LL;  // get<int>() would wrap this
  require_single_error(load_json(j), "/units/0/modbus/port",
                       {"expected an integer in [1, 65535]; got 3000000000"});
  j = demo_json();
  j["units"][0]["modbus"]["port"] = 70000;
  require_single_error(load_json(j), "/units/0/modbus/port",
                       {"expected an integer in [1, 65535]; got 70000"});
  j = demo_json();
  j["units"][0]["modbus"]["unit_id"] = 3000000000LL;
  require_single_error(load_json(j), "/units/0/modbus/unit_id",
                       {"expected an integer in [0, 255]; got 3000000000"});
  j = demo_json();
  j["units"][0]["modbus"]["unit_id"] = -1;
  require_single_error(load_json(j), "/units/0/modbus/unit_id", {"[0, 255]", "got -1"});
  // Beyond 64 bits: nlohmann parses it as a double; still a clean range error.
  require_single_error(load(demo_with("\"port\": 15020", "\"port\": 18446744073709551616")),
                       "/units/0/modbus/port",
                       {"expected an integer in [1, 65535]; got 18446744073709551616"});
}

TEST_CASE("integers are checked for integrality, 502.0 is 502", "[config]") {
  require_single_error(load(demo_with("\"port\": 15020", "\"port\": 1.5")), "/units/0/modbus/port",
                       {"expected an integer in [1, 65535]; got 1.5"});
  require_single_error(load(demo_with("\"address\": 0", "\"address\": 0.5")),
                       "/units/0/points/0/address", {"expected an integer in [0, 65535]; got 0.5"});
  const LoadResult r = load(demo_with("\"port\": 15020", "\"port\": 15020.0"));
  test::require_ok(r);
  CHECK(r.config->units[0].modbus.port == 15020);
  const LoadResult e = load(demo_with("\"port\": 15020", "\"port\": 1.502e4"));
  test::require_ok(e);
  CHECK(e.config->units[0].modbus.port == 15020);
}

TEST_CASE("a number that overflows a double is reported at its pointer", "[config]") {
  require_single_error(load(demo_with("\"poll_period_s\": 0.25", "\"poll_period_s\": 1e400")),
                       "/units/0/modbus/poll_period_s",
                       {"1e400", "out of range of a double", "line 11, column 30"});
  require_single_error(load(demo_with("\"range\": [-20, 50]", "\"range\": [-1e400, 50]")),
                       "/units/0/points/0/range/0", {"-1e400", "out of range"});
}

TEST_CASE("NaN and Infinity are rejected however they are written", "[config]") {
  // Not JSON at all.
  require_single_error(load(demo_with("\"scale\": 0.01", "\"scale\": NaN")), "",
                       {"invalid JSON", "line 24, column 20", "NaN or Infinity"});
  require_single_error(load(demo_with("\"scale\": 0.01", "\"scale\": -Infinity")), "",
                       {"invalid JSON", "NaN or Infinity"});
  // As strings.
  require_single_error(load(demo_with("\"Q_int\": 1.0", "\"Q_int\": \"NaN\"")),
                       "/units/0/estimator/process_noise/Q_int",
                       {"expected a number in [0, ", "got \"NaN\"", "no NaN or Infinity"});
  require_single_error(load(demo_with("\"deadline_s\": 0.5", "\"deadline_s\": \"inf\"")),
                       "/units/0/estimator/deadline_s", {"got \"inf\"", "no NaN or Infinity"});
  // As null, which is how nlohmann-json writes a NaN.
  require_single_error(
      load(demo_with("\"zone_air_temperature\": 0.05", "\"zone_air_temperature\": null")),
      "/units/0/estimator/measurement_noise/zone_air_temperature",
      {"expected a number > 0", "got null"});
}

TEST_CASE("a wrong JSON type names what was expected", "[config]") {
  require_single_error(load(demo_with("\"port\": 15020", "\"port\": \"15020\"")),
                       "/units/0/modbus/port",
                       {"expected an integer", "got \"15020\"", "without quotes"});
  require_single_error(load(demo_with("\"allow_multicast\": false", "\"allow_multicast\": 0")),
                       "/dds/allow_multicast", {"expected true or false; got 0"});
  auto j = demo_json();
  j["units"][0]["modbus"] = 5;
  require_single_error(load_json(j), "/units/0/modbus", {"expected an object; got 5"});
}

TEST_CASE("absurdly deep nesting is rejected without recursion trouble", "[config]") {
  const std::string deep =
      "{\"site_id\": " + std::string(100000, '[') + std::string(100000, ']') + "}";
  const LoadResult r = load(deep);
  INFO(test::describe(r));
  REQUIRE(r.errors.size() == 1);
  CHECK(r.errors[0].pointer.rfind("/site_id/0/0/0/", 0) == 0);
  CHECK(r.errors[0].message.find("nesting deeper than 64") != std::string::npos);
}

// A 15 MB array of zeros under an unknown key made 7.5 M tree nodes and peaked at 900 MB.
TEST_CASE("a document of more than a million values is refused while parsing", "[config]") {
  std::string text = R"({"junk": [)";
  for (int k = 0; k < 1'200'000; ++k)
    text += "0,";
  text += "0]}";
  const LoadResult r = load(text);
  INFO(test::describe(r).substr(0, 2000));
  REQUIRE(r.errors.size() == 1);
  CHECK(r.errors[0].pointer == "/junk/999998");  // the root and the array are values too
  CHECK(r.errors[0].message.find("more than 1000000 values") != std::string::npos);
}

// A million unknown keys held a million messages. The errors kept are the first in document
// order, whatever order the checks found them in: the root's unknown keys, at the start of the
// document, are found last (after every unit's).
TEST_CASE("the loader keeps the first 10 000 errors in document order and counts the rest",
          "[config]") {
  std::string keys;
  for (int k = 0; k < 12'000; ++k)
    keys += "\"u" + std::to_string(k) + "\": 0, ";
  std::string late;  // found first, after the root's keys in the document
  for (int k = 0; k < 50; ++k)
    late += "\"m" + std::to_string(k) + "\": 0, ";
  std::string text = demo_with("{", "{" + keys);
  const auto modbus = text.find("\"modbus\": {");
  REQUIRE(modbus != std::string::npos);
  text.insert(modbus + 11, late);
  const LoadResult r = load(text);
  REQUIRE(r.errors.size() == kMaxKeptErrors);
  CHECK(r.more_errors == 2050);
  CHECK(r.error_count() == 12'050);
  for (std::size_t k = 0; k < r.errors.size(); ++k) {
    INFO("error " << k << ": " << r.errors[k].pointer);
    REQUIRE(r.errors[k].pointer == "/u" + std::to_string(k));
  }
  const std::string shown = format_errors(r.errors, "f");  // the first 100 by default
  CHECK(std::count(shown.begin(), shown.end(), '\n') == static_cast<long>(kMaxShownErrors));
  CHECK(shown.ends_with("f: /u99: " + r.errors[99].message + "\n"));
}

}  // namespace
}  // namespace hvac_twin::config
