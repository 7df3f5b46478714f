// Site, units, Modbus device, DDS and runtime fields: formats, ranges and the rules between them.
#include <catch2/catch.hpp>

#include "config_test_support.hpp"

namespace hvac_twin::config {
namespace {

using nlohmann::json;
using test::demo_json;
using test::load;
using test::load_json;
using test::require_single_error;

json& modbus(json& j) {
  return j["units"][0]["modbus"];
}

TEST_CASE("site_id: required, [A-Za-z0-9_-]+", "[config]") {
  auto j = demo_json();
  j["site_id"] = "demo site";
  require_single_error(load_json(j), "/site_id",
                       {"expected 1 to 64 characters of [A-Za-z0-9_-]; got \"demo site\""});
  j["site_id"] = "";
  require_single_error(load_json(j), "/site_id", {"1 to 64 characters"});
  j["site_id"] = std::string(65, 'a');
  require_single_error(load_json(j), "/site_id", {"1 to 64 characters"});
  j.erase("site_id");
  require_single_error(load_json(j), "", {"missing required field \"site_id\""});
}

TEST_CASE("units: a non-empty array with unique, well-formed ids", "[config]") {
  auto j = demo_json();
  j["units"] = json::array();
  require_single_error(load_json(j), "/units",
                       {"expected a non-empty array of units; got an array"});
  j["units"] = json::object();
  require_single_error(load_json(j), "/units", {"expected a non-empty array", "got an object"});

  j = demo_json();
  j["units"].push_back(j["units"][0]);
  j["units"][1]["modbus"]["port"] = 15021;
  require_single_error(load_json(j), "/units/1/id", {"duplicate unit id \"zone1\"", "/units/0"});
  j["units"][1]["id"] = "zone2";
  test::require_ok(load_json(j));

  j = demo_json();
  j["units"][0]["id"] = "zone/1";
  require_single_error(load_json(j), "/units/0/id", {"[A-Za-z0-9_-]", "got \"zone/1\""});
  j["units"][0].erase("id");
  require_single_error(load_json(j), "/units/0", {"missing required field \"id\""});
  j = demo_json();
  j["units"][0] = "zone1";
  require_single_error(load_json(j), "/units/0", {"expected an object; got \"zone1\""});
}

TEST_CASE("state_directory: absolute or relative to the working directory", "[config]") {
  auto j = demo_json();
  j["state_directory"] = "/var/lib/hvac-twin";
  CHECK(load_json(j).config->state_directory == "/var/lib/hvac-twin");
  j["state_directory"] = "state/dir";
  CHECK(load_json(j).config->state_directory == "state/dir");
  j["state_directory"] = "";
  require_single_error(load_json(j), "/state_directory", {"expected a directory path", "got \"\""});
  j["state_directory"] = "a\nb";
  require_single_error(load_json(j), "/state_directory", {"control characters"});
  j["state_directory"] = 5;
  require_single_error(load_json(j), "/state_directory", {"expected a string; got 5"});
}

TEST_CASE("modbus: host, port, unit id, request size", "[config]") {
  auto j = demo_json();
  modbus(j)["host"] = "plc-7.example.org";
  test::require_ok(load_json(j));
  modbus(j)["host"] = "300.1.2.3";
  require_single_error(load_json(j), "/units/0/modbus/host",
                       {"expected an IPv4 address or a host name; got \"300.1.2.3\""});
  modbus(j)["host"] = "plc 7";
  require_single_error(load_json(j), "/units/0/modbus/host", {"IPv4 address or a host name"});
  modbus(j)["host"] = "-plc";
  require_single_error(load_json(j), "/units/0/modbus/host", {"IPv4 address or a host name"});

  j = demo_json();
  modbus(j)["port"] = 0;
  require_single_error(load_json(j), "/units/0/modbus/port",
                       {"expected an integer in [1, 65535]; got 0"});
  j = demo_json();
  modbus(j)["unit_id"] = 256;
  require_single_error(load_json(j), "/units/0/modbus/unit_id",
                       {"expected an integer in [0, 255]; got 256"});
  j = demo_json();
  modbus(j)["max_registers_per_request"] = 126;
  require_single_error(load_json(j), "/units/0/modbus/max_registers_per_request",
                       {"expected an integer in [1, 125]; got 126"});
  modbus(j)["max_registers_per_request"] = 0;
  require_single_error(load_json(j), "/units/0/modbus/max_registers_per_request",
                       {"[1, 125]", "got 0"});
  // The float32 point needs two registers in one request.
  modbus(j)["max_registers_per_request"] = 1;
  require_single_error(load_json(j), "/units/0/modbus/max_registers_per_request",
                       {"at least 2", "\"hp_heat\""});
}

TEST_CASE("modbus: timeouts and back-off, and the rules between them", "[config]") {
  auto j = demo_json();
  modbus(j)["poll_period_s"] = 0;
  require_single_error(load_json(j), "/units/0/modbus/poll_period_s",
                       {"expected a number in [0.001, 3600] [s]; got 0"});
  // Issue 17 item 8: 1 us burnt 1.5 s of CPU per 8 s while the device was down.
  modbus(j)["poll_period_s"] = 1e-6;
  require_single_error(load_json(j), "/units/0/modbus/poll_period_s",
                       {"expected a number in [0.001, 3600] [s]; got 1e-06"});
  // The poller counts its period in whole nanoseconds and divides by it: 0 ns was a crash.
  modbus(j)["poll_period_s"] = 1e-12;
  modbus(j)["response_timeout_s"] = 1e-13;
  modbus(j)["byte_timeout_s"] = 1e-14;
  require_single_error(load_json(j), "/units/0/modbus/poll_period_s",
                       {"expected a number in [0.001, 3600] [s]; got 1e-12"});
  j = demo_json();
  modbus(j)["response_timeout_s"] = 0.125;  // == poll_period_s / 2
  require_single_error(load_json(j), "/units/0/modbus/response_timeout_s",
                       {"below half of poll_period_s (0.25 s)"});
  // An omitted response_timeout_s takes its default (0.4 s), also too long here: reported at
  // the modbus object, naming the field.
  modbus(j).erase("response_timeout_s");
  require_single_error(load_json(j), "/units/0/modbus",
                       {"response_timeout_s (0.4 s) must be below half of poll_period_s"});
  j = demo_json();
  modbus(j)["byte_timeout_s"] = 0.2;
  require_single_error(load_json(j), "/units/0/modbus/byte_timeout_s",
                       {"byte_timeout_s (0.2 s) must not exceed response_timeout_s (0.1 s)"});
  j = demo_json();
  modbus(j)["backoff_initial_s"] = 6;
  require_single_error(load_json(j), "/units/0/modbus/backoff_initial_s",
                       {"must not exceed backoff_max_s (5 s)"});
  j = demo_json();
  modbus(j)["backoff_max_s"] = -1;
  require_single_error(load_json(j), "/units/0/modbus/backoff_max_s", {"(0, 3600]", "got -1"});
  j = demo_json();
  modbus(j)["response_timeout_s"] = 120;
  require_single_error(load_json(j), "/units/0/modbus/response_timeout_s", {"(0, 60]", "got 120"});
}

TEST_CASE("dds: domain, interface, peers, topic prefix", "[config]") {
  auto j = demo_json();
  j["dds"]["domain_id"] = 233;
  require_single_error(load_json(j), "/dds/domain_id",
                       {"expected an integer in [0, 232]; got 233"});
  j = demo_json();
  j["dds"]["interface"] = "lo\"/><Evil";
  require_single_error(load_json(j), "/dds/interface", {"[A-Za-z0-9_.:-]"});
  j = demo_json();
  j["dds"]["peers"] = json::array();
  require_single_error(load_json(j), "/dds/peers",
                       {"at least one peer", "allow_multicast is false"});
  j["dds"]["allow_multicast"] = true;
  test::require_ok(load_json(j));
  j = demo_json();
  j["dds"]["peers"] = "127.0.0.1";
  require_single_error(load_json(j), "/dds/peers", {"expected an array", "got \"127.0.0.1\""});
  j["dds"]["peers"] = {"127.0.0.1", "a b"};
  require_single_error(load_json(j), "/dds/peers/1", {"got \"a b\""});
  j = demo_json();
  j["dds"]["topic_prefix"] = "hvac/twin";
  require_single_error(load_json(j), "/dds/topic_prefix",
                       {"expected 1 to 64 characters of [A-Za-z0-9_]; got \"hvac/twin\""});
  j = demo_json();
  j.erase("dds");
  const LoadResult r = load_json(j);
  test::require_ok(r);
  CHECK(r.config->dds.peers == std::vector<std::string>{"127.0.0.1"});
}

TEST_CASE("runtime: time scale, hang timeout, watchdog, log level", "[config]") {
  auto j = demo_json();
  j["runtime"]["time_scale"] = 0;
  require_single_error(load_json(j), "/runtime/time_scale",
                       {"expected a number in [0.001, 1e6]; got 0"});
  j["runtime"]["time_scale"] = -60;
  require_single_error(load_json(j), "/runtime/time_scale", {"got -60"});
  j = demo_json();
  j["runtime"]["log_level"] = "verbose";
  require_single_error(load_json(j), "/runtime/log_level",
                       {"expected one of \"trace\", \"debug\", \"info\", \"warn\", \"error\"; got "
                        "\"verbose\""});
  j = demo_json();
  j["runtime"]["overruns_before_watchdog_stop"] = 0;
  require_single_error(load_json(j), "/runtime/overruns_before_watchdog_stop",
                       {"expected an integer in [1, 1000]; got 0"});
  j = demo_json();
  j["runtime"]["recording_budget_mib"] = -1;
  require_single_error(load_json(j), "/runtime/recording_budget_mib",
                       {"expected an integer in [0, 1048576]; got -1"});
  j["runtime"]["recording_budget_mib"] = 0.5;
  require_single_error(load_json(j), "/runtime/recording_budget_mib", {"got 0.5"});
  j = demo_json();
  j["runtime"]["hang_exit"] = "yes";
  require_single_error(load_json(j), "/runtime/hang_exit", {"expected true or false; got \"yes\""});
  j = demo_json();
  j["runtime"]["hang_timeout_s"] = 0.5;  // == the estimator's deadline
  require_single_error(load_json(j), "/units/0/estimator/deadline_s",
                       {"must be below runtime.hang_timeout_s (0.5 s)"});
}

}  // namespace
}  // namespace hvac_twin::config
