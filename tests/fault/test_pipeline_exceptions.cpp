// One unit's pipeline in-process against the fault server answering busy (0x06), its health read
// back over DDS: the polls the device answered only with exceptions count as exception polls and
// never as ok polls (issue 17: modbus_polls_ok rose while every point was DEVICE_EXCEPTION).
#include <catch2/catch.hpp>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <thread>

#include "config/load.hpp"
#include "daemon/runtime/logging.hpp"
#include "daemon/runtime/unit_pipeline.hpp"
#include "io/dds/subscriber.hpp"
#include "io/modbus/poller.hpp"
#include "plant_models/catalog.hpp"
#include "tests/fault/fault_server.hpp"
#include "tests/integration/process.hpp"

using namespace hvac_twin;
using namespace hvac_twin::test_fault;
using namespace std::chrono_literals;

namespace {

constexpr int kDomain = 91;
constexpr std::uint64_t kBusyPolls = 8;

// config/demo.json on the server's port, polling fast, checkpoints in `state`.
config::Config pipeline_config(std::uint16_t port, const std::filesystem::path& state) {
  const std::string text =
      test::Process::read(std::string(HVAC_TWIN_SOURCE_DIR) + "/config/demo.json");
  nlohmann::json c = nlohmann::json::parse(text);
  auto& m = c["units"][0]["modbus"];
  m["port"] = port;
  m["poll_period_s"] = 0.1;  // a busy poll takes three replies and two 20 ms retry delays
  m["response_timeout_s"] = 0.04;
  m["byte_timeout_s"] = 0.02;
  m["backoff_initial_s"] = 0.01;
  m["backoff_max_s"] = 0.2;
  c["dds"]["domain_id"] = kDomain;
  c["state_directory"] = state.string();
  const auto r = config::load_config_text(c.dump(), plant::model_schemas());
  if (!r.config) throw std::runtime_error(config::format_errors(r.errors, "pipeline config"));
  return *r.config;
}

}  // namespace

TEST_CASE("pipeline: polls answered busy are exception polls on the health topic, never ok",
          "[fault][pipeline]") {
  FaultServer server;
  // zone_temp 21.00 degC (x0.01), outdoor_temp 5.0 degC (x0.1), hp_heat 0 kW: one request.
  const std::uint16_t regs[4] = {2100, 50, 0, 0};
  server.set_registers(config::RegisterKind::kInput, 0, regs);
  server.start();
  const auto state = std::filesystem::temp_directory_path() /
                     ("hvac-twin-exceptions-" + std::to_string(::getpid()));
  std::filesystem::remove_all(state);
  const config::Config cfg = pipeline_config(server.port(), state);
  REQUIRE(cfg.units[0].points.size() == 3);
  dds::Participant participant(cfg.dds);
  // Destroyed before the state directory is removed: its checkpoint writer thread may be saving.
  auto owned =
      std::make_unique<runtime::UnitPipeline>(cfg, 0, participant, runtime::make_logger("error"));
  runtime::UnitPipeline& pipeline = *owned;
  dds::Participant reader_side(cfg.dds);  // over the wire (loopback), as a dashboard reads it
  dds::Subscriber reader(reader_side, cfg.dds.topic_prefix,
                         dds::TopicSet{false, true, true, false, false, false});
  pipeline.start();

  std::vector<dds::HealthRecord> health;
  bool busy_observed = false;  // an Observation said DEVICE_EXCEPTION(0x06)
  std::uint64_t cycle = 0;
  // Runs cycles (20 ms apart) until the newest health sample satisfies `done`.
  const auto run_until = [&](auto done) {
    const auto end = std::chrono::steady_clock::now() + 20s;
    while (std::chrono::steady_clock::now() < end) {
      runtime::Tick tick;
      tick.index = ++cycle;
      pipeline.run_cycle(tick);
      std::vector<dds::Record> got;
      reader.wait_and_take(20ms, got);
      for (auto& r : got) {
        if (auto* h = std::get_if<dds::HealthRecord>(&r)) health.push_back(*h);
        if (auto* o = std::get_if<dds::ObservationRecord>(&r))
          busy_observed = busy_observed || (o->quality == dds::PointQuality::kDeviceException &&
                                            o->exception_code == 0x06);
      }
      if (!health.empty() && done(health.back())) return true;
    }
    return false;
  };

  REQUIRE(run_until([](const dds::HealthRecord& h) { return h.modbus_polls_ok >= 2; }));
  const dds::HealthRecord before = health.back();
  CHECK(before.modbus_polls_exception == 0);
  CHECK_FALSE(busy_observed);

  // Every reply busy for kBusyPolls polls: each poll sends the request and retries it twice.
  const std::size_t first_busy = health.size();
  for (std::uint64_t i = 0; i < kBusyPolls * (modbus::Poller::kBusyRetries + 1); ++i)
    server.inject({FaultKind::kException, 0x06});
  REQUIRE(run_until([](const dds::HealthRecord& h) { return h.modbus_polls_exception >= 1; }));
  const std::uint64_t ok_while_busy = health.back().modbus_polls_ok;
  REQUIRE(
      run_until([](const dds::HealthRecord& h) { return h.modbus_polls_exception >= kBusyPolls; }));
  // Two more ok polls once the device answers again.
  REQUIRE(run_until(
      [&](const dds::HealthRecord& h) { return h.modbus_polls_ok >= ok_while_busy + 2; }));
  owned.reset();  // joins the checkpoint writer
  std::error_code ec;
  std::filesystem::remove_all(state, ec);

  const dds::HealthRecord& after = health.back();
  INFO("polls ok " << before.modbus_polls_ok << " -> " << after.modbus_polls_ok << ", exception "
                   << after.modbus_polls_exception << ", failed " << after.modbus_polls_failed
                   << "; last error: " << after.modbus_last_error);
  CHECK(busy_observed);
  CHECK(after.modbus_polls_exception == kBusyPolls);  // exactly the busy polls
  CHECK(after.modbus_polls_failed == before.modbus_polls_failed);
  CHECK(after.modbus_reconnects == 0);
  CHECK(after.modbus_connected);
  // While the device answered busy, the ok count stood still.
  for (std::size_t i = first_busy; i < health.size(); ++i) {
    const auto& h = health[i];
    if (h.modbus_polls_exception >= 1 && h.modbus_polls_exception < kBusyPolls)
      CHECK(h.modbus_polls_ok == ok_while_busy);
  }
}
