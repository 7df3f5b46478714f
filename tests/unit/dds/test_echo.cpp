// hvac-twin-echo: option parsing, formatting, and the built binary end to end over loopback.
#include <catch2/catch.hpp>
#include <csignal>
#include <cstdlib>
#include <ctime>
#include <nlohmann/json.hpp>
#include <string>

#include "dds_test_support.hpp"
#include "io/dds/echo/format.hpp"
#include "io/dds/echo/options.hpp"
#include "io/dds/publisher.hpp"

using namespace hvac_twin::dds;
using namespace std::chrono_literals;
using nlohmann::json;

namespace {
constexpr int kDomainEchoJson = 109;
constexpr int kDomainEchoText = 110;
constexpr int kDomainEchoSignal = 112;

echo::Options parse(std::vector<const char*> args) {
  args.insert(args.begin(), "hvac-twin-echo");
  return echo::parse_options(static_cast<int>(args.size()), args.data());
}

std::vector<std::string> echo_command(int domain, std::vector<std::string> extra) {
  std::vector<std::string> argv = {HVAC_TWIN_ECHO_PATH,
                                   "--domain",
                                   std::to_string(domain),
                                   "--interface",
                                   "lo",
                                   "--peer",
                                   "127.0.0.1",
                                   "--topic-prefix",
                                   test::loopback_config(domain).topic_prefix};
  argv.insert(argv.end(), extra.begin(), extra.end());
  return argv;
}

VirtualSensorRecord sample_vs_record() {
  VirtualSensorRecord r;
  r.site = "site";
  r.unit = "hp1";
  r.name = "zone_air_temperature";
  r.value = 21.4321;
  r.sigma = 0.05;
  r.eng_unit = "degC";
  r.quality = EstimateQuality::kGood;
  r.flags = kFlagPredictOnly | kFlagConstraintActive;
  r.timestamp_ns = 1'700'000'405'000'000'000;  // 2023-11-14 22:20:05 UTC
  r.cycle = 42;
  return r;
}
}  // namespace

TEST_CASE("echo options: defaults and every option", "[dds][echo]") {
  const echo::Options defaults = parse({});
  CHECK(defaults.dds.domain_id == 0);
  CHECK(defaults.dds.interface == "lo");
  CHECK_FALSE(defaults.dds.allow_multicast);
  CHECK(defaults.dds.peers == std::vector<std::string>{"127.0.0.1"});
  CHECK(defaults.dds.topic_prefix == "hvac_twin");
  CHECK(defaults.topics.virtual_sensor);
  CHECK(defaults.topics.observation);
  CHECK(defaults.topics.estimator_health);
  CHECK_FALSE(defaults.count);
  CHECK_FALSE(defaults.duration_s);
  CHECK(defaults.format == echo::Format::kJson);

  const echo::Options o =
      parse({"--domain", "7", "--interface=eth1", "--peer", "10.0.0.1", "--peer=10.0.0.2",
             "--topic-prefix", "plant", "--topics", "observation,estimator_health", "--count", "5",
             "--duration", "2.5", "--format", "text"});
  CHECK(o.dds.domain_id == 7);
  CHECK(o.dds.interface == "eth1");
  CHECK(o.dds.peers == std::vector<std::string>{"10.0.0.1", "10.0.0.2"});
  CHECK(o.dds.topic_prefix == "plant");
  CHECK_FALSE(o.topics.virtual_sensor);
  CHECK(o.topics.observation);
  CHECK(o.topics.estimator_health);
  CHECK(o.count == 5u);
  CHECK(o.duration_s == 2.5);
  CHECK(o.format == echo::Format::kText);
  CHECK(parse({"--help"}).help);
}

TEST_CASE("echo options: mistakes are usage errors", "[dds][echo]") {
  CHECK_THROWS_AS(parse({"--domain", "233"}), echo::UsageError);
  CHECK_THROWS_AS(parse({"--domain", "x"}), echo::UsageError);
  CHECK_THROWS_AS(parse({"--count", "0"}), echo::UsageError);
  CHECK_THROWS_AS(parse({"--count"}), echo::UsageError);
  CHECK_THROWS_AS(parse({"--duration", "-1"}), echo::UsageError);
  CHECK_THROWS_AS(parse({"--topics", "virtual_sensor,bogus"}), echo::UsageError);
  CHECK_THROWS_AS(parse({"--format", "xml"}), echo::UsageError);
  CHECK_THROWS_AS(parse({"--topic-prefix", "a/b"}), echo::UsageError);
  CHECK_THROWS_AS(parse({"--interface", "lo\""}), echo::UsageError);
  CHECK_THROWS_AS(parse({"--frobnicate"}), echo::UsageError);
}

TEST_CASE("echo formats: JSON has every field, text is one aligned line", "[dds][echo]") {
  const Record record = sample_vs_record();
  const json j = json::parse(echo::to_json_line(record));
  CHECK(j.at("topic") == "virtual_sensor");
  CHECK(j.at("site") == "site");
  CHECK(j.at("unit") == "hp1");
  CHECK(j.at("name") == "zone_air_temperature");
  CHECK(j.at("value").get<double>() == 21.4321);
  CHECK(j.at("sigma").get<double>() == 0.05);
  CHECK(j.at("eng_unit") == "degC");
  CHECK(j.at("quality") == "GOOD");
  CHECK(j.at("flags") == 3);
  CHECK(j.at("flag_names") == json::array({"predict_only", "constraint_active"}));
  CHECK(j.at("timestamp_ns").get<std::int64_t>() == 1'700'000'405'000'000'000);
  CHECK(j.at("cycle") == 42);
  CHECK(echo::to_json_line(record).find('\n') == std::string::npos);

  setenv("TZ", "UTC", 1);
  tzset();
  const std::string text = echo::to_text_line(record);
  INFO(text);
  CHECK(text.rfind("22:20:05 hp1      zone_air_temperature ", 0) == 0);
  CHECK(text.find("21.43 ± 0.05") != std::string::npos);
  CHECK(text.find("degC     GOOD  [predict_only,constraint_active]") != std::string::npos);
  // A value that rounds to zero at the sigma's digits prints as 0, not -0.
  VirtualSensorRecord near_zero = sample_vs_record();
  near_zero.value = -0.004;
  near_zero.sigma = 2.0;
  CHECK(echo::to_text_line(Record(near_zero)).find(" 0 ± 2 ") != std::string::npos);
  near_zero.value = -0.6;
  CHECK(echo::to_text_line(Record(near_zero)).find(" -1 ± 2 ") != std::string::npos);

  HealthRecord health;
  health.unit = "hp1";
  health.modbus_polls_ok = 3;
  health.modbus_polls_exception = 40;
  health.modbus_polls_failed = 2;
  health.modbus_last_error = "timeout";
  const std::string health_text = echo::to_text_line(health);
  CHECK(health_text.find("health cycle 0") != std::string::npos);
  CHECK(health_text.find("modbus DOWN ok 3 exception 40 fail 2 ") != std::string::npos);
  CHECK(health_text.find("last error: timeout") != std::string::npos);

  ObservationRecord obs;
  obs.quality = PointQuality::kDeviceException;
  obs.exception_code = 2;
  CHECK(echo::to_text_line(obs).find("DEVICE_EXCEPTION(2)") != std::string::npos);
  CHECK(json::parse(echo::to_json_line(obs)).at("quality") == "DEVICE_EXCEPTION");
}

TEST_CASE("echo formats the leak diagnostic: JSON every field, text the alarm and hold",
          "[dds][echo]") {
  LeakDiagnosticRecord r;
  r.site = "site";
  r.unit = "hp1";
  r.state = LeakState::kLeak;
  r.hold = LeakHold::kStartUp;
  r.charge = 0.4512;
  r.charge_sigma = 0.004;
  r.nameplate_charge = 0.5;
  r.leak_rate = 2.1;
  r.leak_rate_sigma = 0.3;
  r.cusum = 14.0;
  r.rate_cusum = 3.5;
  r.charge_cusum = 14.0;
  r.charge_reference = 0.5312;
  r.threshold = 12.0;
  r.false_alarm_interval_days = 3650.0;
  r.decisions = 17;
  r.suspect_since_ns = 5;
  r.leak_since_ns = 6;
  r.quality = EstimateQuality::kDegraded;
  r.timestamp_ns = 1'700'000'405'000'000'000;
  r.cycle = 9;
  const json j = json::parse(echo::to_json_line(r));
  CHECK(j.at("topic") == "leak_diagnostic");
  CHECK(j.at("state") == "LEAK");
  CHECK(j.at("hold") == "START_UP");
  CHECK(j.at("charge").get<double>() == 0.4512);
  CHECK(j.at("leak_rate").get<double>() == 2.1);
  CHECK(j.at("threshold").get<double>() == 12.0);
  CHECK(j.at("rate_cusum").get<double>() == 3.5);
  CHECK(j.at("charge_cusum").get<double>() == 14.0);
  CHECK(j.at("charge_reference").get<double>() == 0.5312);
  CHECK(j.at("decisions") == 17);
  CHECK(j.at("leak_since_ns") == 6);
  CHECK(j.at("quality") == "DEGRADED");
  CHECK(j.size() == 22);  // every wire field plus "topic"

  setenv("TZ", "UTC", 1);
  tzset();
  const std::string text = echo::to_text_line(r);
  INFO(text);
  CHECK(text.find("leak   LEAK") != std::string::npos);
  CHECK(text.find("charge 0.4512 ± 0.0040 kg (nameplate 0.500)") != std::string::npos);
  CHECK(text.find("CUSUM rate 3.50 charge 14.00 / 12.00") != std::string::npos);
  CHECK(text.find("held: START_UP") != std::string::npos);
  r.hold = LeakHold::kNone;
  CHECK(echo::to_text_line(r).find("held") == std::string::npos);

  CHECK_THROWS_WITH(parse({"--topics", "leak"}), Catch::Contains("leak_diagnostic"));
  const auto only_leak = parse({"--topics", "leak_diagnostic"});
  CHECK(only_leak.topics.contains(Topic::kLeakDiagnostic));
  CHECK_FALSE(only_leak.topics.contains(Topic::kVirtualSensor));
}

TEST_CASE("echo formats the estimator consistency: JSON every field, text the verdict",
          "[dds][echo]") {
  ConsistencyRecord r;
  r.site = "site";
  r.unit = "hp1";
  r.point = "suction_pressure";
  r.window_cycles = 360;
  r.samples = 358;
  r.mean_nis = 3.25;
  r.band_low = 0.856;
  r.band_high = 1.152;
  r.verdict = ConsistencyVerdict::kHigh;
  r.rejected_share = 0.0625;
  r.timestamp_ns = 1'700'000'405'000'000'000;
  r.cycle = 12;
  const json j = json::parse(echo::to_json_line(r));
  CHECK(j.at("topic") == "estimator_consistency");
  CHECK(j.at("site") == "site");
  CHECK(j.at("unit") == "hp1");
  CHECK(j.at("point") == "suction_pressure");
  CHECK(j.at("window_cycles") == 360);
  CHECK(j.at("samples") == 358);
  CHECK(j.at("mean_nis").get<double>() == 3.25);
  CHECK(j.at("band_low").get<double>() == 0.856);
  CHECK(j.at("band_high").get<double>() == 1.152);
  CHECK(j.at("verdict") == "HIGH");
  CHECK(j.at("rejected_share").get<double>() == 0.0625);
  CHECK(j.at("timestamp_ns").get<std::int64_t>() == r.timestamp_ns);
  CHECK(j.at("cycle") == 12);
  CHECK(j.size() == 13);  // every wire field plus "topic"

  setenv("TZ", "UTC", 1);
  tzset();
  const std::string text = echo::to_text_line(r);
  INFO(text);
  CHECK(text.rfind("22:20:05 hp1      nis suction_pressure ", 0) == 0);
  CHECK(text.find("mean   3.25  band [0.86, 1.15]") != std::string::npos);
  CHECK(text.find("358 samples / 360 cycles  rejected  6.2 %  HIGH") != std::string::npos);

  CHECK_THROWS_WITH(parse({"--topics", "consistency"}), Catch::Contains("estimator_consistency"));
  const auto only = parse({"--topics", "estimator_consistency"});
  CHECK(only.topics.contains(Topic::kEstimatorConsistency));
  CHECK_FALSE(only.topics.contains(Topic::kEstimatorHealth));
  CHECK(parse({}).topics.contains(Topic::kEstimatorConsistency));  // all by default
}

TEST_CASE("echo formats the unit estimate: JSON every entry, text one line per cycle",
          "[dds][echo]") {
  UnitEstimateRecord r;
  r.site = "site";
  r.unit = "hp1";
  r.estimates = {{"charge", 0.5123, 0.02, "kg"}, {"superheat", 6.25, 0.4, "K"}};
  r.quality = EstimateQuality::kDegraded;
  r.flags = kFlagDeadlineOverrun;
  r.fused_points = 0x7F;
  r.timestamp_ns = 1'700'000'405'000'000'000;
  r.cycle = 77;
  const json j = json::parse(echo::to_json_line(r));
  CHECK(j.at("topic") == "unit_estimate");
  CHECK(j.at("site") == "site");
  CHECK(j.at("unit") == "hp1");
  CHECK(j.at("quality") == "DEGRADED");
  CHECK(j.at("flags") == kFlagDeadlineOverrun);
  CHECK(j.at("flag_names") == json::array({"deadline_overrun"}));
  CHECK(j.at("fused_points") == 0x7F);
  REQUIRE(j.at("estimates").size() == 2);
  CHECK(j.at("estimates")[1].at("name") == "superheat");
  CHECK(j.at("estimates")[1].at("value").get<double>() == 6.25);
  CHECK(j.at("estimates")[1].at("sigma").get<double>() == 0.4);
  CHECK(j.at("estimates")[1].at("eng_unit") == "K");
  CHECK(j.at("estimates")[0].at("value").get<double>() == 0.5123);
  CHECK(j.at("timestamp_ns").get<std::int64_t>() == r.timestamp_ns);
  CHECK(j.at("cycle") == 77);
  CHECK(j.size() == 10);

  setenv("TZ", "UTC", 1);
  tzset();
  const std::string text = echo::to_text_line(r);
  INFO(text);
  CHECK(text.rfind("22:20:05 hp1      unit   cycle 77 ", 0) == 0);
  CHECK(text.find("2 estimates  DEGRADED  [deadline_overrun]") != std::string::npos);

  const auto only = parse({"--topics", "unit_estimate"});
  CHECK(only.topics.contains(Topic::kUnitEstimate));
  CHECK_FALSE(only.topics.contains(Topic::kVirtualSensor));
  CHECK(parse({}).topics.contains(Topic::kUnitEstimate));  // all by default
}

TEST_CASE("hvac-twin-echo prints every sample as a JSON line over loopback", "[dds][echo]") {
  const auto config = test::loopback_config(kDomainEchoJson);
  Participant participant(config);
  UnitPublisher publisher(participant, config.topic_prefix, "site-a", "hp1", 1s);
  const std::int64_t t = test::now_ns();

  VirtualSensorSample vs;
  vs.name = "refrigerant_charge";
  vs.value = 1.2345678901234567;
  vs.sigma = 0.0123;
  vs.eng_unit = "kg";
  vs.quality = EstimateQuality::kNotReady;
  vs.flags = kFlagColdStart;
  vs.timestamp_ns = t;
  vs.cycle = 9;
  ObservationSample obs;
  obs.point = "supply_air_temperature";
  obs.value = 35.5;
  obs.quality = PointQuality::kStale;
  obs.predicted = 35.0;
  obs.innovation = 0.5;
  obs.innovation_variance = 0.04;
  obs.test_ratio = 6.25;
  obs.fused = false;
  obs.timestamp_ns = t;
  obs.cycle = 9;
  HealthSample health;
  health.cycle = 9;
  health.cycle_time_ms = 4.5;
  health.cycle_time_max_ms = 8.0;
  health.quality = EstimateQuality::kDegraded;
  health.modbus_connected = true;
  health.modbus_polls_ok = 90;
  health.modbus_polls_exception = 12;
  health.modbus_polls_failed = 1;
  health.modbus_last_error = "Connection timed out";
  health.timestamp_ns = t;
  // Published before the echo starts: it receives them as a late joiner, over the network.
  REQUIRE(publisher.publish(vs) == PublishStatus::kOk);
  REQUIRE(publisher.publish(obs) == PublishStatus::kOk);
  REQUIRE(publisher.publish(health) == PublishStatus::kOk);

  test::ChildProcess echo_process(
      echo_command(kDomainEchoJson, {"--count", "3", "--duration", "60", "--format", "json"}));
  const auto lines = echo_process.read_lines(3, 60s);
  INFO("stderr: " << echo_process.stderr_text());
  REQUIRE(lines.size() == 3);
  CHECK(echo_process.wait(30s) == 0);

  std::map<std::string, json> by_topic;
  for (const auto& line : lines) {
    const json j = json::parse(line);
    by_topic[j.at("topic").get<std::string>()] = j;
  }
  REQUIRE(by_topic.size() == 3);

  const json& v = by_topic.at("virtual_sensor");
  CHECK(v.at("site") == "site-a");
  CHECK(v.at("unit") == "hp1");
  CHECK(v.at("name") == "refrigerant_charge");
  CHECK(v.at("value").get<double>() == vs.value);  // shortest round-trip repr: bit-exact
  CHECK(v.at("sigma").get<double>() == vs.sigma);
  CHECK(v.at("eng_unit") == "kg");
  CHECK(v.at("quality") == "NOT_READY");
  CHECK(v.at("flags") == kFlagColdStart);
  CHECK(v.at("flag_names") == json::array({"cold_start"}));
  CHECK(v.at("timestamp_ns").get<std::int64_t>() == t);
  CHECK(v.at("cycle") == 9);

  const json& o = by_topic.at("observation");
  CHECK(o.at("point") == "supply_air_temperature");
  CHECK(o.at("value").get<double>() == 35.5);
  CHECK(o.at("quality") == "STALE");
  CHECK(o.at("exception_code") == 0);
  CHECK(o.at("predicted").get<double>() == 35.0);
  CHECK(o.at("innovation").get<double>() == 0.5);
  CHECK(o.at("innovation_variance").get<double>() == 0.04);
  CHECK(o.at("test_ratio").get<double>() == 6.25);
  CHECK(o.at("fused") == false);
  CHECK(o.at("timestamp_ns").get<std::int64_t>() == t);
  CHECK(o.at("cycle") == 9);

  const json& h = by_topic.at("estimator_health");
  CHECK(h.at("unit") == "hp1");
  CHECK(h.at("cycle") == 9);
  CHECK(h.at("cycle_time_ms").get<double>() == 4.5);
  CHECK(h.at("cycle_time_max_ms").get<double>() == 8.0);
  CHECK(h.at("quality") == "DEGRADED");
  CHECK(h.at("modbus_connected") == true);
  CHECK(h.at("modbus_polls_ok") == 90);
  CHECK(h.at("modbus_polls_exception") == 12);
  CHECK(h.at("modbus_polls_failed") == 1);
  CHECK(h.at("modbus_reconnects") == 0);
  CHECK(h.at("modbus_last_error") == "Connection timed out");
  CHECK(h.at("publish_rejections") == 0);
  CHECK(h.at("timestamp_ns").get<std::int64_t>() == t);
  for (const char* key : {"overruns", "degraded_cycles", "gate_rejections", "numerical_resets"}) {
    CHECK(h.at(key) == 0);
  }
}

TEST_CASE("hvac-twin-echo --topics and --format text", "[dds][echo]") {
  const auto config = test::loopback_config(kDomainEchoText);
  Participant participant(config);
  UnitPublisher publisher(participant, config.topic_prefix, "site", "hp1", 1s);
  VirtualSensorSample vs;
  vs.name = "zone_air_temperature";
  vs.value = 21.43;
  vs.sigma = 0.05;
  vs.eng_unit = "degC";
  vs.quality = EstimateQuality::kGood;
  vs.timestamp_ns = test::now_ns();
  HealthSample health;
  health.timestamp_ns = vs.timestamp_ns;
  REQUIRE(publisher.publish(health) == PublishStatus::kOk);  // filtered out by --topics
  REQUIRE(publisher.publish(vs) == PublishStatus::kOk);

  test::ChildProcess echo_process(echo_command(
      kDomainEchoText,
      {"--topics", "virtual_sensor", "--count", "1", "--duration", "60", "--format", "text"}));
  const auto lines = echo_process.read_lines(1, 60s);
  INFO("stderr: " << echo_process.stderr_text());
  REQUIRE(lines.size() == 1);
  CHECK(lines[0].find("hp1      zone_air_temperature") != std::string::npos);
  CHECK(lines[0].find("21.43 ± 0.05") != std::string::npos);
  CHECK(lines[0].find("GOOD") != std::string::npos);
  CHECK(echo_process.wait(30s) == 0);
}

TEST_CASE("hvac-twin-echo exits cleanly on SIGTERM and SIGINT", "[dds][echo]") {
  for (const int signal : {SIGTERM, SIGINT}) {
    test::ChildProcess echo_process(echo_command(kDomainEchoSignal, {}));
    REQUIRE(echo_process.wait_for_stderr("hvac-twin-echo: domain", 60s));
    echo_process.send_signal(signal);
    CHECK(echo_process.wait(30s) == 0);
  }
}
