// `hvac-twind --check-config` over a set of broken configurations, as an operator or a
// deployment script sees it: exit status 78, exactly one line per error naming the file and the
// JSON pointer, in document order, then one summary line; nothing silently accepted (integer
// overflow, duplicate keys, unknown keys, non-finite numbers, wrong types).
#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "tests/integration/process.hpp"
#include "tests/support/scratch_dir.hpp"

using namespace hvac_twin::test;
using namespace std::chrono_literals;

namespace {

std::string demo_text() {
  return Process::read(std::string(HVAC_TWIN_SOURCE_DIR) + "/config/demo.json");
}

// The demo text with the first occurrence of each `from` replaced by its `to`.
std::string edited(std::vector<std::pair<std::string, std::string>> edits) {
  std::string text = demo_text();
  for (const auto& [from, to] : edits) {
    const auto at = text.find(from);
    if (at == std::string::npos) throw std::runtime_error("not in demo.json: " + from);
    text.replace(at, from.size(), to);
  }
  return text;
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line))
    out.push_back(line);
  return out;
}

// The demo text with `count` more measured points (holding registers 100, 101, ...).
std::string with_measured_points(int count) {
  std::string points = "\"points\": [";
  for (int k = 0; k < count; ++k)
    points += R"({"name": "extra_)" + std::to_string(k) + R"(", "address": )" +
              std::to_string(100 + k) +
              R"(, "unit": "degC", "range": [-20, 50], "signal": "zone_air_temperature"},)";
  return edited({{"\"points\": [", points}});
}

struct Case {
  std::string name;
  std::string text;
  std::vector<std::string> pointers;  // expected, in order; "(root)" for the document
  std::string message;                // a part of the first error's message
};

std::vector<Case> cases() {
  const std::string big_nesting = std::string(100000, '[') + std::string(100000, ']');
  std::string deepest;  // the loader stops at 64 levels and names where
  for (int i = 0; i < 64; ++i)
    deepest += "/0";
  return {
      {"port-overflow",
       edited({{"\"port\": 15020", "\"port\": 4294967298"}}),
       {"/units/0/modbus/port"},
       "expected an integer in [1, 65535]"},
      {"unit-id-wraps-int",
       edited({{"\"unit_id\": 1", "\"unit_id\": 3000000000"}}),
       {"/units/0/modbus/unit_id"},
       "3000000000"},
      {"huge-integer",
       edited({{"\"max_registers_per_request\": 125", "\"max_registers_per_request\": 1e20"}}),
       {"/units/0/modbus/max_registers_per_request"},
       "expected an integer"},
      {"negative-address",
       edited({{"\"address\": 0", "\"address\": -1"}}),
       {"/units/0/points/0/address"},
       "address"},
      {"fractional-integer",
       edited({{"\"unit_id\": 1", "\"unit_id\": 1.5"}}),
       {"/units/0/modbus/unit_id"},
       "integer"},
      {"duplicate-key",
       edited({{"\"port\": 15020,", "\"port\": 15020, \"port\": 15021,"}}),
       {"/units/0/modbus/port"},
       "duplicate"},
      {"duplicate-top-level-key",
       edited({{"\"site_id\": \"demo-site\",", "\"site_id\": \"a\", \"site_id\": \"b\","}}),
       {"/site_id"},
       "duplicate"},
      {"unknown-key",
       edited({{"\"state_directory\"", "\"state_dir\""}}),
       {"/state_dir"},
       "unknown key"},
      {"misspelt-required-key",
       edited({{"\"address\": 0", "\"adress\": 0"}}),
       {"/units/0/points/0", "/units/0/points/0/adress"},
       ""},
      {"number-overflows-double",
       edited({{"\"poll_period_s\": 0.25", "\"poll_period_s\": 1e400"}}),
       {"/units/0/modbus/poll_period_s"},
       ""},
      {"nan-literal",
       edited({{"\"poll_period_s\": 0.25", "\"poll_period_s\": NaN"}}),
       {"(root)"},
       "invalid JSON"},
      {"wrong-types",
       edited({{"\"port\": 15020", "\"port\": \"15020\""},
               {"\"time_scale\": 60", "\"time_scale\": true"}}),
       {"/units/0/modbus/port", "/runtime/time_scale"},
       "expected"},
      {"control-characters-stay-on-one-line",
       edited({{"\"site_id\": \"demo-site\"", "\"site_id\": \"demo\\nsite\\u0000\""}}),
       {"/site_id"},
       R"(got "demo\nsite\u0000")"},
      {"several-errors-one-line-each",
       edited({{"\"port\": 15020", "\"port\": 0"},
               {"\"type\": \"int16\"", "\"type\": \"int64\""},
               {"\"C_air\": 2.0e6", "\"C_air\": -1"},
               {"\"log_level\": \"info\"", "\"log_level\": \"loud\""}}),
       {"/units/0/modbus/port", "/units/0/points/0/type", "/units/0/model/parameters/C_air",
        "/runtime/log_level"},
       ""},
      {"duplicate-key-in-a-map",
       edited({{"\"C_air\": 2.0e6,", "\"C_air\": 2.0e6, \"C_air\": 3e6,"}}),
       {"/units/0/model/parameters/C_air"},
       "duplicate"},
      {"duplicate-key-spelt-with-escapes",
       edited({{"\"site_id\": \"demo-site\",", "\"site_id\": \"a\", \"s\\u0069te_id\": \"b\","}}),
       {"/site_id"},
       "duplicate"},
      {"exponent-overflow",
       edited({{"\"port\": 15020", "\"port\": 1e999999999"}}),
       {"/units/0/modbus/port"},
       "out of range of a double"},
      {"five-thousand-digits",
       edited({{"\"port\": 15020", "\"port\": " + std::string(5000, '7')}}),
       {"/units/0/modbus/port"},
       ""},
      {"boolean-for-integer",
       edited({{"\"unit_id\": 1", "\"unit_id\": true"}}),
       {"/units/0/modbus/unit_id"},
       "got true"},
      {"quoted-number",
       edited({{"\"range\": [-20, 50]", "\"range\": [\"-20\", 50]"}}),
       {"/units/0/points/0/range/0"},
       "expected a number"},
      {"empty", "", {"(root)"}, "empty"},
      {"binary",
       std::string("\x7f"
                   "ELF\x02\x01\x01\0\0\0",
                   10),
       {"(root)"},
       "invalid JSON"},
      {"truncated", demo_text().substr(0, 700), {"(root)"}, "invalid JSON"},
      {"deep-nesting", big_nesting, {deepest}, "nesting deeper than 64 levels"},
      {"not-an-object", "[1, 2, 3]", {"(root)"}, "expected an object"},
      // Refused at start-up (exit 1) or crashed the poller, after the check had passed them:
      // the fused points of a cycle are a 64-bit mask; the runtime counts periods and the
      // deadline in whole nanoseconds; DDS takes a period of at most 24 h.
      {"65-measured-points",
       with_measured_points(64),
       {"/units/0/points"},
       "65 points have role \"measured\""},
      {"wall-period-rounds-to-0-ns",
       edited({{"\"period_s\": 60", "\"period_s\": 1e-12, \"consistency_window_s\": 1e-10"},
               {"\"deadline_s\": 0.5", "\"deadline_s\": 1e-15"}}),
       {"/units/0/estimator/period_s", "/units/0/estimator/deadline_s"},
       "[1e-9, 86400]"},
      {"wall-period-over-24-h",
       edited({{"\"period_s\": 60", "\"period_s\": 86400"},
               {"\"time_scale\": 60", "\"time_scale\": 0.5"}}),
       {"/units/0/estimator/period_s"},
       "172800 s"},
      {"poll-period-rounds-to-0-ns",
       edited({{"\"poll_period_s\": 0.25", "\"poll_period_s\": 1e-12"},
               {"\"response_timeout_s\": 0.1", "\"response_timeout_s\": 1e-13"},
               {"\"byte_timeout_s\": 0.05", "\"byte_timeout_s\": 1e-14"}}),
       {"/units/0/modbus/poll_period_s"},
       "[0.001, 3600]"},
  };
}

}  // namespace

TEST_CASE("check-config: one line per error, at its JSON pointer, and exit 78",
          "[integration][cli][config]") {
  const ScratchDir scratch("check");
  const std::filesystem::path& dir = scratch.path();
  std::vector<Case> all = cases();
  all.push_back({"missing-file", "", {"(root)"}, ""});
  for (const Case& c : all) {
    INFO("case " << c.name);
    const std::string file = (dir / (c.name + ".json")).string();
    if (c.name != "missing-file") std::ofstream(file, std::ios::binary) << c.text;
    Process check(HVAC_TWIND_EXE, {"--check-config", file}, file + ".out", file + ".err");
    const auto rc = check.wait(20s);
    REQUIRE(rc.has_value());
    const auto err = lines(check.err());
    INFO("stderr:\n" << check.err());
    CHECK(*rc == 78);
    CHECK(check.out().empty());
    REQUIRE(err.size() == c.pointers.size() + 1);
    for (std::size_t i = 0; i < c.pointers.size(); ++i) {
      const std::string prefix = file + ": " + c.pointers[i] + ": ";
      CHECK(err[i].rfind(prefix, 0) == 0);   // starts with file and pointer
      CHECK(err[i].size() > prefix.size());  // and says what is wrong
    }
    if (!c.message.empty()) CHECK_THAT(err[0], Catch::Contains(c.message));
    CHECK(err.back() == file + ": " + std::to_string(c.pointers.size()) + " error(s)");
  }

  // A file of more than 16 MiB is refused before it is parsed.
  const std::string huge = (dir / "huge.json").string();
  {
    std::ofstream f(huge);
    f << "{\"site_id\": \"" << std::string(17u << 20, 'x') << "\"}";
  }
  Process big(HVAC_TWIND_EXE, {"--check-config", huge}, huge + ".out", huge + ".err");
  REQUIRE(big.wait(20s) == 78);
  CHECK(lines(big.err()).size() == 2);

  // The daemon itself refuses to start on any of them, with the same status; among them those
  // that start-up refused with status 1.
  for (const std::string name :
       {"duplicate-key", "65-measured-points", "wall-period-rounds-to-0-ns",
        "wall-period-over-24-h", "poll-period-rounds-to-0-ns"}) {
    INFO("case " << name);
    const std::string file = (dir / (name + ".json")).string();
    Process daemon(HVAC_TWIND_EXE, {"--config", file}, file + ".d.out", file + ".d.err");
    REQUIRE(daemon.wait(20s) == 78);
    CHECK_THAT(daemon.err(), Catch::Contains("not starting"));
  }
}

// A hostile file: a million unknown keys printed a million lines. The first 100 errors are
// printed and one line says how many more there were, by --check-config and at start-up.
TEST_CASE("check-config and start-up print at most 100 errors and count the rest",
          "[integration][cli][config]") {
  const ScratchDir scratch("cap");
  const std::filesystem::path& dir = scratch.path();
  std::string keys;
  for (int k = 0; k < 1000; ++k)
    keys += "\"unknown_" + std::to_string(k) + "\": 0, ";
  const std::string file = (dir / "unknown-keys.json").string();
  std::ofstream(file, std::ios::binary) << edited({{"{", "{" + keys}});

  Process check(HVAC_TWIND_EXE, {"--check-config", file}, file + ".out", file + ".err");
  REQUIRE(check.wait(20s) == 78);
  const auto err = lines(check.err());
  INFO("stderr:\n" << check.err());
  REQUIRE(err.size() <= 101);
  REQUIRE(err.size() == 101);
  for (int k = 0; k < 100; ++k)  // the first 100, in document order
    CHECK(err[static_cast<std::size_t>(k)].rfind(
              file + ": /unknown_" + std::to_string(k) + ": unknown key", 0) == 0);
  CHECK(err.back() == file + ": 1000 error(s), 900 more not shown");

  Process daemon(HVAC_TWIND_EXE, {"--config", file}, file + ".d.out", file + ".d.err");
  REQUIRE(daemon.wait(20s) == 78);
  const auto daemon_err = lines(daemon.err());
  INFO("daemon stderr:\n" << daemon.err());
  REQUIRE(daemon_err.size() <= 101);
  CHECK(daemon_err.size() == 101);
  CHECK_THAT(daemon_err.back(),
             Catch::Contains("900 more error(s) not shown") && Catch::Contains("not starting"));
}

TEST_CASE("check-config accepts every configuration the repository ships",
          "[integration][cli][config]") {
  // Every *.json directly in config/ (config/examples/ holds the broken ones on purpose).
  std::size_t checked = 0;
  const ScratchDir dir("cc-ok");
  for (const auto& entry :
       std::filesystem::directory_iterator(std::string(HVAC_TWIN_SOURCE_DIR) + "/config")) {
    if (entry.path().extension() != ".json") continue;
    const std::string file = entry.path().string();
    INFO(file);
    Process check(HVAC_TWIND_EXE, {"--check-config", file}, dir / "out", dir / "err");
    REQUIRE(check.wait(20s) == 0);
    ++checked;
  }
  CHECK(checked >= 1);
}
