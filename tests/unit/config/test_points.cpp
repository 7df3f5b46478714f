// Points: register layout, decoding fields, units, and how points feed the model.
#include <catch2/catch.hpp>
#include <map>
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
using test::require_single_error;

json& point(json& j, int i) {
  return j["units"][0]["points"][i];
}

TEST_CASE("point type, register kind and role are checked against their lists", "[config]") {
  auto j = demo_json();
  point(j, 2)["type"] = "float";
  require_single_error(
      load_json(j), "/units/0/points/2/type",
      {R"(expected one of "int16", "uint16", "int32", "uint32", "float32"; got "float")"});
  j = demo_json();
  point(j, 0)["register"] = "coil";
  require_single_error(load_json(j), "/units/0/points/0/register",
                       {R"(expected one of "holding", "input"; got "coil")"});
  j = demo_json();
  point(j, 0)["role"] = "sensor";
  require_single_error(load_json(j), "/units/0/points/0/role",
                       {R"(expected one of "measured", "input", "disturbance"; got "sensor")"});
}

TEST_CASE("word order must suit the type: 16-bit values take ABCD or BADC only", "[config]") {
  auto j = demo_json();
  point(j, 0)["word_order"] = "CDAB";
  require_single_error(load_json(j), "/units/0/points/0/word_order",
                       {"\"CDAB\" is not a byte order of a 16-bit value", "\"int16\"",
                        "expected \"ABCD\" or \"BADC\""});
  point(j, 0)["word_order"] = "BADC";
  test::require_ok(load_json(j));
  point(j, 2)["word_order"] = "DCBA";  // float32: all four
  test::require_ok(load_json(j));
  point(j, 2)["word_order"] = "DCAB";
  require_single_error(load_json(j), "/units/0/points/2/word_order",
                       {R"(expected one of "ABCD", "CDAB", "BADC", "DCBA"; got "DCAB")"});
}

TEST_CASE("scale is a non-zero number, offset a number", "[config]") {
  auto j = demo_json();
  point(j, 0)["scale"] = 0;
  require_single_error(load_json(j), "/units/0/points/0/scale",
                       {"expected a non-zero number; got 0"});
  point(j, 0)["scale"] = "0.01";
  require_single_error(load_json(j), "/units/0/points/0/scale",
                       {"non-zero number", "got \"0.01\""});
  j = demo_json();
  point(j, 0)["offset"] = true;
  require_single_error(load_json(j), "/units/0/points/0/offset", {"expected a number; got true"});
  point(j, 0)["offset"] = -0.5;
  point(j, 0)["scale"] = -0.01;
  test::require_ok(load_json(j));
}

TEST_CASE("range is [min, max] with min < max", "[config]") {
  auto j = demo_json();
  point(j, 0)["range"] = {50, -20};
  require_single_error(load_json(j), "/units/0/points/0/range",
                       {"expected [min, max] with min < max; got [50, -20]"});
  point(j, 0)["range"] = {5, 5};
  require_single_error(load_json(j), "/units/0/points/0/range", {"min < max", "got [5, 5]"});
  point(j, 0)["range"] = {-20};
  require_single_error(load_json(j), "/units/0/points/0/range",
                       {"expected [min, max]", "got an array of 1 elements"});
  point(j, 0)["range"] = {"low", 50};
  require_single_error(load_json(j), "/units/0/points/0/range/0",
                       {"expected a number; got \"low\""});
  point(j, 0)["range"] = json::object({{"min", -20}, {"max", 50}});
  require_single_error(load_json(j), "/units/0/points/0/range",
                       {"expected [min, max]", "an object"});
  point(j, 0).erase("range");
  require_single_error(load_json(j), "/units/0/points/0", {"missing required field \"range\""});
}

TEST_CASE("address: an integer register address that fits the value", "[config]") {
  auto j = demo_json();
  point(j, 0)["address"] = 65536;
  require_single_error(load_json(j), "/units/0/points/0/address",
                       {"expected an integer in [0, 65535]; got 65536"});
  j = demo_json();
  point(j, 2)["address"] = 65535;
  require_single_error(
      load_json(j), "/units/0/points/2/address",
      {"2-register \"float32\" value at address 65535 runs past the last register"});
  point(j, 2)["address"] = 65534;
  test::require_ok(load_json(j));
  point(j, 0).erase("address");
  require_single_error(load_json(j), "/units/0/points/0", {"missing required field \"address\""});
}

TEST_CASE("registers of two points of the same kind must not overlap", "[config]") {
  auto j = demo_json();
  point(j, 1)["address"] = 3;  // the float32 hp_heat occupies input registers 2-3
  require_single_error(load_json(j), "/units/0/points/2/address",
                       {"input registers 2-3 overlap input register 3 of point \"outdoor_temp\""});
  point(j, 1)["register"] = "holding";  // another register space: no overlap
  test::require_ok(load_json(j));
  j = demo_json();
  point(j, 1)["address"] = 0;
  require_single_error(
      load_json(j), "/units/0/points/1/address",
      {"input register 0 overlap input register 0 of point \"zone_temp\"", "/units/0/points/0"});
}

// "p17". (`"p" + std::to_string(k)` trips GCC 12's -Wrestrict false positive, bug 105329.)
template <class Int>
std::string numbered(std::string prefix, Int k) {
  prefix += std::to_string(k);
  return prefix;
}

// The errors whose message contains `word`, by pointer.
std::map<std::string, std::string> errors_with(const LoadResult& r, std::string_view word) {
  std::map<std::string, std::string> out;
  for (const auto& e : r.errors)
    if (e.message.find(word) != std::string::npos) out[e.pointer] = e.message;
  return out;
}

// Overlaps and duplicate names were found by comparing every pair of points (60 000 points took
// 12 s). Whatever the method, the result is the pairwise rule's: a point whose registers overlap
// those of an earlier point of the same kind is reported once, at its address, naming the first
// such point; a name used before is reported at the later point, naming the first.
TEST_CASE("overlaps and duplicate names among many points are those of the pairwise rule",
          "[config]") {
  std::mt19937 rng(17);
  auto j = demo_json();
  json& points = j["units"][0]["points"];
  const json measured = points[0];
  for (int k = 0; k < 3000; ++k) {
    json p = measured;
    p["register"] = rng() % 2 == 0 ? "holding" : "input";
    p["type"] = rng() % 4 == 0 ? "float32" : "int16";
    p["address"] = rng() % 4000;
    p["name"] = numbered("p", rng() % 2900);  // many names repeat
    points.push_back(p);
  }
  // Expected, pair by pair.
  std::map<std::string, std::string> overlaps;
  std::map<std::string, std::string> names;
  const auto span = [](const json& p) {
    const int first = p["address"].get<int>();
    return std::pair{first, first + (p.value("type", "uint16") == "float32" ? 2 : 1)};
  };
  for (std::size_t i = 0; i < points.size(); ++i) {
    const std::string at = "/units/0/points/" + std::to_string(i);
    for (std::size_t k = 0; k < i; ++k) {
      if (points[k]["name"] != points[i]["name"]) continue;
      names[at + "/name"] = "/units/0/points/" + std::to_string(k);
      break;
    }
    const auto [first, end] = span(points[i]);
    for (std::size_t k = 0; k < i; ++k) {
      const auto [other_first, other_end] = span(points[k]);
      if (points[k]["register"] != points[i]["register"] || !(first < other_end) ||
          !(other_first < end))
        continue;
      overlaps[at + "/address"] = "(/units/0/points/" + std::to_string(k) + ")";
      break;
    }
  }
  const LoadResult r = load_json(j);
  const auto found_overlaps = errors_with(r, " overlap ");
  const auto found_names = errors_with(r, "duplicate point name");
  CHECK(overlaps.size() > 100);
  CHECK(names.size() > 10);
  CHECK(found_overlaps.size() == overlaps.size());
  CHECK(found_names.size() == names.size());
  for (const auto& [pointer, first] : overlaps) {
    INFO(pointer << " should name " << first);
    REQUIRE(found_overlaps.contains(pointer));
    CHECK_THAT(found_overlaps.at(pointer), Catch::EndsWith(first));
  }
  for (const auto& [pointer, first] : names) {
    INFO(pointer << " should name " << first);
    REQUIRE(found_names.contains(pointer));
    CHECK_THAT(found_names.at(pointer), Catch::EndsWith(first));
  }
}

TEST_CASE("60 000 points: the overlaps and the duplicate name planted among them", "[config]") {
  auto j = demo_json();
  json& points = j["units"][0]["points"];
  const std::size_t first = points.size();
  const json measured = points[0];
  constexpr int kPoints = 60000;
  for (int k = 0; k < kPoints; ++k) {  // holding registers 0 to 59999, one each
    json p = measured;
    p["register"] = "holding";
    p["address"] = k;
    p["name"] = numbered("p", k);
    points.push_back(p);
  }
  const auto at = [&](int k) { return "/units/0/points/" + std::to_string(first + k); };
  const auto add = [&](std::string name, std::string kind, std::string type, int address) {
    json p = measured;
    p["name"] = name;
    p["register"] = kind;
    p["type"] = type;
    p["address"] = address;
    points.push_back(p);
  };
  add("wide_last", "holding", "float32", kPoints - 1);  // k = kPoints: overlaps the last
  add("after_last", "holding", "int16", kPoints);       // overlaps wide_last's second register
  add("wide_middle", "holding", "int32", 29999);        // overlaps p29999 and p30000
  add("input_five", "input", "int16", 5);               // another register space: free
  add("p123", "holding", "int16", kPoints + 1);         // free registers, a used name
  const LoadResult r = load_json(j);
  INFO(test::describe(r).substr(0, 2000));
  const auto overlaps = errors_with(r, " overlap ");
  const auto names = errors_with(r, "duplicate point name");
  CHECK(overlaps == std::map<std::string, std::string>{
                        {at(kPoints) + "/address",
                         "holding registers 59999-60000 overlap holding register 59999 of point "
                         "\"p59999\" (" +
                             at(kPoints - 1) + ")"},
                        {at(kPoints + 1) + "/address",
                         "holding register 60000 overlap holding registers 59999-60000 of point "
                         "\"wide_last\" (" +
                             at(kPoints) + ")"},
                        {at(kPoints + 2) + "/address",
                         "holding registers 29999-30000 overlap holding register 29999 of point "
                         "\"p29999\" (" +
                             at(29999) + ")"},
                    });
  CHECK(names == std::map<std::string, std::string>{
                     {at(kPoints + 4) + "/name",
                      "duplicate point name \"p123\"; also the name of " + at(123)}});
  CHECK(r.errors.size() == overlaps.size() + names.size() + 1);  // + too many measured points
}

TEST_CASE("point names are [A-Za-z0-9_]+ and unique within the unit", "[config]") {
  auto j = demo_json();
  point(j, 1)["name"] = "zone_temp";
  require_single_error(load_json(j), "/units/0/points/1/name",
                       {"duplicate point name \"zone_temp\"", "/units/0/points/0"});
  point(j, 1)["name"] = "outdoor-temp";
  require_single_error(load_json(j), "/units/0/points/1/name",
                       {"expected 1 to 64 characters of [A-Za-z0-9_]; got \"outdoor-temp\""});
}

TEST_CASE("a point's signal must exist in the model, on the side its role says", "[config]") {
  auto j = demo_json();
  point(j, 0)["signal"] = "zone_air_temp";
  require_single_error(load_json(j), "/units/0/points/0/signal",
                       {"unknown model output \"zone_air_temp\" of model \"zone_rc\"",
                        "did you mean \"zone_air_temperature\"?", "\"envelope_heat_loss\""});
  j = demo_json();
  point(j, 2)["signal"] = "zone_air_temperature";
  // hp_heat no longer feeds heat_pump_heat either, but that follows from this one error.
  require_single_error(load_json(j), "/units/0/points/2/signal",
                       {"\"zone_air_temperature\" is a model output",
                        "a point with role \"input\" must name a model input",
                        "\"heat_pump_heat\", \"outdoor_temperature\""});
  j = demo_json();
  point(j, 0)["role"] = "input";
  require_single_error(load_json(j), "/units/0/points/0/signal", {"is a model output"});
  j = demo_json();
  point(j, 0).erase("signal");
  require_single_error(load_json(j), "/units/0/points/0", {"missing required field \"signal\""});
}

TEST_CASE("a point's unit must be known and convertible to its signal's unit", "[config]") {
  auto j = demo_json();
  point(j, 2)["unit"] = "kw";
  require_single_error(load_json(j), "/units/0/points/2/unit",
                       {"unknown unit \"kw\"", "did you mean \"kW\"?", "known units:"});
  point(j, 2)["unit"] = "kPa";
  require_single_error(
      load_json(j), "/units/0/points/2/unit",
      {"unit \"kPa\" cannot be converted to \"W\"", "model input \"heat_pump_heat\""});
  point(j, 2)["unit"] = "W";
  test::require_ok(load_json(j));
  point(j, 0)["unit"] = "K";
  test::require_ok(load_json(j));
  point(j, 0)["unit"] = "degF";
  test::require_ok(load_json(j));
}

TEST_CASE("every required model input is fed by exactly one point", "[config]") {
  auto j = demo_json();
  j["units"][0]["points"].erase(1);  // outdoor_temp
  require_single_error(load_json(j), "/units/0/points",
                       {"model input \"outdoor_temperature\" [degC] of model \"zone_rc\"",
                        "no point feeds it", "role \"input\" or \"disturbance\""});
  j = demo_json();
  json second = point(j, 1);
  second["name"] = "outdoor_temp2";
  second["address"] = 10;
  j["units"][0]["points"].push_back(second);
  require_single_error(load_json(j), "/units/0/points/3/signal",
                       {"model input \"outdoor_temperature\" is already fed by point "
                        "\"outdoor_temp\""});
}

TEST_CASE("several measured points may share an output", "[config]") {
  auto j = demo_json();
  json second = point(j, 0);
  second["name"] = "zone_temp_2";
  second["address"] = 10;
  j["units"][0]["points"].push_back(second);
  test::require_ok(load_json(j));
}

// The daemon publishes the points fused in a cycle as a 64-bit mask, and refused more at
// start-up (exit 1) after --check-config had passed them.
TEST_CASE("a unit takes at most 64 measured points", "[config]") {
  auto j = demo_json();
  const json measured = point(j, 0);
  for (int k = 1; k < 64; ++k) {
    json extra = measured;
    extra["name"] = "zone_temp_" + std::to_string(k);
    extra["address"] = 100 + k;
    j["units"][0]["points"].push_back(extra);
  }
  test::require_ok(load_json(j));  // 64 measured points
  json extra = measured;
  extra["name"] = "zone_temp_64";
  extra["address"] = 164;
  j["units"][0]["points"].push_back(extra);
  require_single_error(load_json(j), "/units/0/points",
                       {"65 points have role \"measured\"", "at most 64"});
  // Points with other roles do not count.
  j["units"][0]["points"].back()["role"] = "disturbance";
  j["units"][0]["points"].back()["signal"] = "outdoor_temperature";
  j["units"][0]["points"].erase(1);  // the other outdoor_temperature point
  test::require_ok(load_json(j));
}

TEST_CASE("a unit needs points, and at least one measured point", "[config]") {
  auto j = demo_json();
  j["units"][0]["points"] = json::array();
  require_single_error(load_json(j), "/units/0/points", {"expected a non-empty array of points"});
  j["units"][0].erase("points");
  require_single_error(load_json(j), "/units/0", {"missing required field \"points\""});
  j = demo_json();
  point(j, 0)["signal"] = "outdoor_temperature";
  point(j, 0)["role"] = "disturbance";
  j["units"][0]["points"].erase(1);
  j["units"][0]["estimator"].erase("measurement_noise");
  j["units"][0]["estimator"]["measurement_noise"] = json::object();
  require_single_error(load_json(j), "/units/0/points", {"no point has role \"measured\""});
}

TEST_CASE("stale_after_s must exceed the poll period", "[config]") {
  auto j = demo_json();
  point(j, 0)["stale_after_s"] = 0.25;
  require_single_error(load_json(j), "/units/0/points/0/stale_after_s",
                       {"stale_after_s (0.25 s) must exceed the unit's modbus poll_period_s "
                        "(0.25 s)"});
  point(j, 0)["stale_after_s"] = 0;
  require_single_error(load_json(j), "/units/0/points/0/stale_after_s",
                       {"expected a number in (0, 86400] [s]; got 0"});
  // A default that does not fit is reported at the point, naming the field.
  j = demo_json();
  j["units"][0]["modbus"]["poll_period_s"] = 20;
  j["units"][0]["modbus"]["response_timeout_s"] = 5;
  j["units"][0]["modbus"]["byte_timeout_s"] = 1;
  point(j, 0)["stale_after_s"] = 60;
  point(j, 1)["stale_after_s"] = 60;
  require_single_error(load_json(j), "/units/0/points/2", {"stale_after_s (10 s) must exceed"});
}

}  // namespace
}  // namespace hvac_twin::config
