// A unit's only available point, rejected max_consecutive_rejections times in a row while its
// reading moves, is tested against the initial covariance (the EKF) or spread (the EnKF) and let
// back in when plausible there; an absurd or a frozen reading is not, and a point rejected while
// another is fused is left to the gate. Both filters, and without a heap allocation.
#include <catch2/catch.hpp>
#include <memory>
#include <vector>

#include "daemon/estimation/ekf.hpp"
#include "daemon/estimation/enkf.hpp"
#include "plant_models/core/ad_model.hpp"
#include "test_models.hpp"
#include "tests/support/alloc_counter.hpp"

using namespace hvac_twin;
using test::AllocationScope;

namespace {

// Process noise too small for the filter ever to doubt itself by predicting.
template <class Filter>
std::unique_ptr<est::Estimator> make(const plant::ContinuousModel& model, std::size_t points) {
  if constexpr (std::is_same_v<Filter, est::Ekf>) {
    return std::make_unique<est::Ekf>(model, std::vector<double>(model.num_states(), 1e-9), points,
                                      est::EkfOptions{});
  } else {
    est::EnkfOptions o;
    o.members = 64;
    o.threads = 1;
    return std::make_unique<est::ConstrainedEnkf>(
        model, std::vector<double>(model.num_states(), 1e-9), points, o);
  }
}

est::Measurement meas(double value) {
  return {.output = 0, .value = value, .variance = 1e-4, .available = true};
}

// A live sensor: its reading moves by its noise from one update to the next.
est::Measurement reading(double value, int k) {
  return meas(value + (k % 2 ? 0.005 : -0.005));
}

}  // namespace

TEMPLATE_TEST_CASE("the only available point, rejected in a row, is let back in when plausible",
                   "[ekf][enkf][gate][alloc]", est::Ekf, est::ConstrainedEnkf) {
  const plant::AdModel<test::RandomWalk> model{test::RandomWalk{}};
  const auto filter = make<TestType>(model, 1);
  est::Estimator& f = *filter;
  f.reset(std::vector<double>{0.0}, std::vector<double>{1.0});  // max_consecutive_rejections 5
  est::MeasurementReport rep;
  for (int k = 0; k < 3; ++k) {
    auto m = reading(0.0, k);
    REQUIRE(f.update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kOk);
  }
  REQUIRE(f.covariance()(0, 0) < 1e-4);
  const double sure = f.state()(0);
  REQUIRE(sure == Approx(0.0).margin(0.01));

  SECTION("a step the filter cannot follow: re-admitted at the fifth rejection, then fused") {
    // NIS ~ 2000 against the prior, ~0.25 against the initial covariance.
    const AllocationScope scope;
    for (int k = 1; k <= 4; ++k) {
      auto m = reading(0.5, k);
      REQUIRE(f.update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kOk);
      CHECK(rep.rejected);
    }
    CHECK(f.state()(0) == sure);
    auto m = reading(0.5, 5);
    REQUIRE(f.update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kOk);
    CHECK(rep.fused);
    CHECK_FALSE(rep.faulty);
    CHECK(f.counters().covariance_resets == 1);
    CHECK(f.state()(0) == Approx(0.5).margin(0.02));
    for (int k = 6; k < 26; ++k) {
      m = reading(0.5, k);
      REQUIRE(f.update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kOk);
      CHECK(rep.fused);
    }
    CHECK(f.counters().covariance_resets == 1);
    CHECK(f.counters().gate_rejections == 4);
    CHECK(scope.count() == 0);
  }
  SECTION("an absurd reading stays out, and costs no reset") {
    const AllocationScope scope;
    for (int k = 0; k < 200; ++k) {
      auto m = reading(50.0, k);  // NIS ~ 2500 against the initial covariance too
      REQUIRE(f.update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kOk);
      CHECK(rep.rejected);
    }
    CHECK(f.state()(0) == Approx(sure).margin(1e-12));
    CHECK(f.counters().covariance_resets == 0);
    CHECK(scope.count() == 0);
  }
  SECTION("a frozen reading, the same value every time, is left to the stuck check") {
    auto m = meas(0.5);
    for (int k = 0; k < 200; ++k) {
      REQUIRE(f.update({&m, 1}, {}, {&rep, 1}) == est::StepStatus::kOk);
      CHECK(rep.rejected);
    }
    CHECK(f.state()(0) == sure);
    CHECK(f.counters().covariance_resets == 0);
  }
}

TEMPLATE_TEST_CASE("a point rejected while another is fused is not let back in by a reset",
                   "[ekf][enkf][gate]", est::Ekf, est::ConstrainedEnkf) {
  const plant::AdModel<test::StructuralError> model{test::StructuralError{}};
  const auto filter = make<TestType>(model, 2);
  est::Estimator& f = *filter;
  f.reset(std::vector<double>{0.0}, std::vector<double>{1.0});
  // y = x right, "twice" reading 1 where the model says 0: plausible against the initial
  // covariance (S0 ~ 4), never against the posterior the first point keeps tight.
  std::vector<est::Measurement> z{meas(0.0), meas(1.0)};
  z[1].output = 1;
  std::vector<est::MeasurementReport> reps(2);
  z[1].available = false;  // the first point alone first: both at once would meet half-way
  for (int k = 0; k < 3; ++k)
    REQUIRE(f.update(z, {}, reps) == est::StepStatus::kOk);
  z[1].available = true;
  for (int k = 0; k < 100; ++k) {
    z[0] = reading(0.0, k);
    z[1].value = 1.0 + (k % 2 ? 0.005 : -0.005);
    REQUIRE(f.update(z, {}, reps) == est::StepStatus::kOk);
    CHECK(reps[0].fused);
    CHECK(reps[1].rejected);
  }
  CHECK(f.counters().covariance_resets == 0);
  CHECK(f.state()(0) == Approx(0.0).margin(0.01));
}
