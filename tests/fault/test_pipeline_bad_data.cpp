// One unit's pipeline in-process, fed bad register data by the fault server: after every cycle
// the filter's state is finite and its covariance finite and positive definite (Cholesky), no
// numerical reset was needed, nothing reached the publisher's non-finite guard, and the values
// outside the model's physical range were refused by the pipeline's own guard.
#include <Eigen/Cholesky>
#include <bit>
#include <catch2/catch.hpp>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "config/load.hpp"
#include "daemon/runtime/logging.hpp"
#include "daemon/runtime/unit_pipeline.hpp"
#include "plant_models/catalog.hpp"
#include "tests/fault/fault_server.hpp"
#include "tests/integration/process.hpp"

using namespace hvac_twin;
using namespace hvac_twin::test_fault;
using namespace std::chrono_literals;

namespace {

constexpr std::uint16_t kZone = 4;  // zone_temp float32 ABCD at input registers 4-5
constexpr std::uint16_t kHeat = 2;  // hp_heat float32 CDAB at input registers 2-3

void set_float(FaultServer& s, std::uint16_t address, float value, bool cdab) {
  const auto bits = std::bit_cast<std::uint32_t>(value);
  const auto hi = static_cast<std::uint16_t>(bits >> 16), lo = static_cast<std::uint16_t>(bits);
  const std::uint16_t regs[2] = {cdab ? lo : hi, cdab ? hi : lo};
  s.set_registers(config::RegisterKind::kInput, address, regs);
}

config::Config pipeline_config(std::uint16_t port) {
  const std::string text =
      test::Process::read(std::string(HVAC_TWIN_SOURCE_DIR) + "/config/demo.json");
  nlohmann::json c = nlohmann::json::parse(text);
  auto& unit = c["units"][0];
  auto& m = unit["modbus"];
  m["port"] = port;
  m["poll_period_s"] = 0.05;
  m["response_timeout_s"] = 0.02;
  m["byte_timeout_s"] = 0.01;
  m["backoff_initial_s"] = 0.01;
  m["backoff_max_s"] = 0.2;
  auto& zone = unit["points"][0];
  zone["address"] = kZone;
  zone["type"] = "float32";
  zone.erase("scale");
  zone["range"] = {-100, 100};               // wider than the model's -40..70 degC
  unit["points"][2]["range"] = {-100, 100};  // wider than the model's -30..30 kW
  c["dds"]["domain_id"] = 90;
  const auto r = config::load_config_text(c.dump(), plant::model_schemas());
  if (!r.config) throw std::runtime_error(config::format_errors(r.errors, "pipeline config"));
  return *r.config;
}

bool spd(const Eigen::MatrixXd& p) {
  return p.allFinite() && Eigen::LLT<Eigen::MatrixXd>(p).info() == Eigen::Success;
}

}  // namespace

TEST_CASE(
    "pipeline: bad data keeps x finite and P positive definite, nothing non-finite is "
    "published",
    "[fault][pipeline]") {
  FaultServer server;
  const auto serve_good = [&] {
    set_float(server, kZone, 21.0f, false);
    set_float(server, kHeat, 2.0f, true);
    const std::uint16_t outdoor = 50;  // 5.0 degC at scale 0.1
    server.set_registers(config::RegisterKind::kInput, 1, std::span(&outdoor, 1));
  };
  serve_good();
  server.start();
  const config::Config cfg = pipeline_config(server.port());
  dds::Participant participant(cfg.dds);
  runtime::UnitPipeline pipeline(cfg, 0, participant, runtime::make_logger("error"));
  pipeline.start();

  std::uint64_t cycle = 0, ran = 0;
  bool healthy = true;
  const auto run = [&](int cycles) {
    for (int i = 0; i < cycles; ++i) {
      runtime::Tick tick;
      tick.index = ++cycle;
      const auto out = pipeline.run_cycle(tick);
      const auto& f = pipeline.filter();
      ran += out.ran_estimator ? 1 : 0;
      healthy = healthy && (!out.ran_estimator || (f.state().allFinite() && spd(f.covariance())));
      std::this_thread::sleep_for(20ms);
    }
  };
  std::this_thread::sleep_for(200ms);  // the first polls
  run(20);                             // settle on good data
  REQUIRE(ran == 20);
  REQUIRE(healthy);

  const float inf = std::numeric_limits<float>::infinity();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  struct Phase {
    const char* what;
    bool zone;
    float value;
    bool refused_by_pipeline;  // GOOD at the poller, outside the model's range
  };
  const std::vector<Phase> phases = {
      {"zone NaN", true, nan, false},           {"zone +Inf", true, inf, false},
      {"zone huge", true, -3e38f, false},       {"zone denormal", true, 1e-40f, false},
      {"zone 90 degC", true, 90.0f, true},      {"heat NaN", false, nan, false},
      {"heat -Inf", false, -inf, false},        {"heat huge", false, 3e38f, false},
      {"heat denormal", false, -1e-45f, false}, {"heat 80 kW", false, 80.0f, true},
  };
  for (const Phase& p : phases) {
    INFO("phase " << p.what);
    const auto before = pipeline.guards();
    set_float(server, p.zone ? kZone : kHeat, p.value, !p.zone);
    std::this_thread::sleep_for(150ms);  // three polls
    run(10);
    CHECK(healthy);
    const auto after = pipeline.guards();
    if (p.refused_by_pipeline) {
      CHECK((p.zone ? after.measurements_refused - before.measurements_refused
                    : after.inputs_refused - before.inputs_refused) >= 8);
    }
    serve_good();
    std::this_thread::sleep_for(150ms);
    run(10);
  }
  // A point that turns to garbage: random bits on both float points, changing every cycle.
  std::mt19937 rng(5);
  for (int i = 0; i < 100; ++i) {
    const std::uint16_t regs[4] = {
        static_cast<std::uint16_t>(rng()), static_cast<std::uint16_t>(rng()),
        static_cast<std::uint16_t>(rng()), static_cast<std::uint16_t>(rng())};
    server.set_registers(config::RegisterKind::kInput, kHeat, regs);
    run(1);
  }
  CHECK(healthy);
  const auto stats = pipeline.publisher_stats();
  const auto& counters = pipeline.filter().counters();
  INFO("published " << stats.published << ", refused " << stats.rejected() << "; fused "
                    << counters.fused << ", gate rejections " << counters.gate_rejections
                    << ", numerical resets " << counters.numerical_resets << "; guards: inputs "
                    << pipeline.guards().inputs_refused << ", measurements "
                    << pipeline.guards().measurements_refused);
  CHECK(stats.published > 0);
  CHECK(stats.rejected_non_finite == 0);
  CHECK(stats.rejected() == 0);
  CHECK(counters.numerical_resets == 0);
  CHECK(counters.fused > 0);
  pipeline.stop();
}
