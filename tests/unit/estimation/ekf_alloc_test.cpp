// The periodic path allocates nothing: predict, update and output estimates after start-up.
#include <catch2/catch.hpp>
#include <memory>
#include <vector>

#include "daemon/estimation/ekf.hpp"
#include "plant_models/core/ad_model.hpp"
#include "plant_models/core/integrator.hpp"
#include "plant_models/zone/zone_rc.hpp"
#include "tests/support/alloc_counter.hpp"

using hvac_twin::test::AllocationScope;

using namespace hvac_twin;

TEST_CASE("an EKF cycle on the zone model makes no heap allocation", "[ekf][alloc]") {
  const plant::AdModel<plant::ZoneRc> model{plant::ZoneRc(plant::ZoneRc::Params{})};
  est::Ekf ekf(model, std::vector<double>{0.01, 0.001, 1.0}, 1, est::EkfOptions{});
  ekf.reset(std::vector<double>{20.0, 20.0, 300.0}, std::vector<double>{1.0, 2.0, 200.0});
  const std::vector<double> u{2000.0, 5.0};
  std::vector<double> y(model.num_outputs()), sigma(model.num_outputs());
  est::MeasurementReport rep;
  est::Measurement m{.output = 0, .value = 20.5, .variance = 0.01, .available = true};

  {  // Sanity: the counter sees allocations at all.
    const AllocationScope probe_scope;
    auto probe = std::make_unique<std::vector<int>>(8);
    REQUIRE(probe_scope.count() >= 1);
  }

  ekf.predict(u, 60.0);  // warm-up
  const AllocationScope scope;
  for (int k = 0; k < 50; ++k) {
    ekf.predict(u, 60.0);
    m.value = 20.5 + 0.01 * k;
    ekf.update({&m, 1}, u, {&rep, 1});
    ekf.output_estimates(u, y, sigma);
  }
  CHECK(scope.count() == 0);
  CHECK(ekf.counters().fused == 50);
}

#include "plant_models/catalog.hpp"

// The heat pump as the demo configures it: every parameter the filter estimates augmented.
plant::ParameterMap demo_heat_pump() {
  return {{"augment_fouling", 1},          {"augment_evap_ua_factor", 1},
          {"augment_comp_flow_factor", 1}, {"augment_comp_efficiency_factor", 1},
          {"augment_void_exponent", 1},    {"augment_cond_htc_factor", 1},
          {"augment_evap_htc_factor", 1}};
}

TEST_CASE("a constrained EKF cycle on the heat pump makes no heap allocation", "[ekf][alloc]") {
  // With either way of taking F: the filters' direct solve, and the matrix exponentials.
  const auto method =
      GENERATE(plant::SensitivityMethod::kDirect, plant::SensitivityMethod::kExponential);
  INFO("sensitivity method " << static_cast<int>(method));
  const auto model = plant::create_model("heat_pump_r32", demo_heat_pump());
  const auto& L = model->layout();
  std::vector<double> q, s0, x0;
  for (const auto& s : L.states) {
    q.push_back(s.process_noise);
    s0.push_back(0.2 * s.initial_std);
    x0.push_back(s.initial);
  }
  est::EkfOptions options;
  options.constrained = true;
  options.integrator.sensitivity_method = method;
  est::Ekf ekf(*model, q, 2, options);
  ekf.reset(x0, s0);
  const std::vector<double> u{50.0, 0.355, 1.0, 1.0, 35.0};
  std::vector<double> y(model->num_outputs()), sigma(model->num_outputs());
  REQUIRE(model->outputs(x0, u, y) == plant::kModelOk);
  // Measurements off by a few sigma so that updates move the state.
  std::vector<est::Measurement> z{
      {.output = 0, .value = y[0] + 8e3, .variance = 25e6, .available = true},
      {.output = 1, .value = y[1] - 2e4, .variance = 225e6, .available = true}};
  std::vector<est::MeasurementReport> reps(2);
  REQUIRE(ekf.predict(u, 2.0) == est::StepStatus::kOk);  // warm-up
  const AllocationScope scope;
  int predicted = 0;
  for (int k = 0; k < 5; ++k) {
    predicted += ekf.predict(u, 2.0) == est::StepStatus::kOk ? 1 : 0;
    ekf.update(z, u, reps);
    ekf.output_estimates(u, y, sigma);
  }
  CHECK(scope.count() == 0);
  CHECK(predicted == 5);
  CHECK((ekf.integrator().last_stats().segments > 0) ==
        (method == plant::SensitivityMethod::kExponential));
  CHECK(ekf.counters().fused >= 5);
}

#include "daemon/estimation/enkf.hpp"

TEST_CASE("a constrained EnKF cycle on the heat pump, on two threads, makes no heap allocation",
          "[enkf][alloc]") {
  const auto model = plant::create_model("heat_pump_r32", demo_heat_pump());
  const auto& L = model->layout();
  std::vector<double> q, s0, x0;
  for (const auto& s : L.states) {
    q.push_back(s.process_noise);
    s0.push_back(0.05 * s.initial_std);
    x0.push_back(s.initial);
  }
  const std::vector<double> u{50.0, 0.374, 1.0, 1.0, 35.0};
  // From the operating point (the layout's initial state moves by 100 kPa in seconds, which
  // would put the measurements below outside the gate).
  REQUIRE(plant::Integrator(*model, {}).step(x0, u, 600.0, {}).ok());
  est::EnkfOptions options;
  options.members = 16;
  options.threads = 2;
  est::ConstrainedEnkf enkf(*model, q, 2, options);
  enkf.reset(x0, s0);
  std::vector<double> y(model->num_outputs()), sigma(model->num_outputs());
  REQUIRE(model->outputs(x0, u, y) == plant::kModelOk);
  std::vector<est::Measurement> z{
      {.output = 0, .value = y[0] + 8e3, .variance = 25e6, .available = true},
      {.output = 1, .value = y[1] - 2e4, .variance = 225e6, .available = true}};
  std::vector<est::MeasurementReport> reps(2);
  REQUIRE(enkf.predict(u, 2.0) == est::StepStatus::kOk);  // warm-up
  const AllocationScope scope;
  for (int k = 0; k < 3; ++k) {
    enkf.predict(u, 2.0);
    enkf.update(z, u, reps);
    enkf.output_estimates(u, y, sigma);
  }
  CHECK(scope.count() == 0);
  CHECK(enkf.counters().fused >= 3);
}

#include "daemon/estimation/consistency_monitor.hpp"

TEST_CASE("the consistency monitor allocates nothing after construction", "[consistency][alloc]") {
  est::ConsistencyMonitor monitor(3,
                                  est::ConsistencyOptions{.window_cycles = 50, .min_samples = 5});
  std::vector<est::MeasurementReport> reps(3);
  const AllocationScope scope;
  for (int k = 0; k < 400; ++k) {  // fill, evict, recompute, and a new band for every k
    for (std::size_t i = 0; i < reps.size(); ++i) {
      reps[i].available = (k + static_cast<int>(i)) % 5 != 0;
      reps[i].test_ratio = 0.01 * (k % 97) + static_cast<double>(i);
      reps[i].rejected = k % 13 == 0;
    }
    if (k % 11 == 0)
      monitor.skip();
    else
      monitor.add(reps);
  }
  CHECK(scope.count() == 0);
  CHECK(monitor.overall().verdict != est::ConsistencyVerdict::kInsufficientData);
}
