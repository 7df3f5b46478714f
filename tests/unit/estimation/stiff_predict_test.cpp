// The EKF's health check after a prediction whose covariance is positive semi-definite but not
// definite in doubles: F P F' through a stiff model, where fast modes decay to nothing and leave
// variances 1e16 apart (on the heat pump at tests/unit/plant_models/stiff_state.hpp, with every
// sigma at 10 % of its initial one, F P F' had eigenvalues of -1e-14 of the largest; an EKF
// there with every sigma at 3 % reset its prediction, and the leak benchmark's filter reset
// three in a row).
#include <catch2/catch.hpp>
#include <vector>

#include "daemon/estimation/ekf.hpp"
#include "plant_models/core/ad_model.hpp"

using namespace hvac_twin;

namespace {

// Two tanks that equalise in microseconds: x' = k [x2 - x1, x1 - x2]. Over a second F is
// [[1, 1], [1, 1]] / 2 to the last digit, so F P F' is singular and its factorisation fails.
struct Equalising {
  plant::ModelLayout layout() const {
    plant::ModelLayout l;
    for (const char* name : {"a", "b"})
      l.states.push_back(plant::StateInfo{.name = name, .unit = "1", .abs_tol = 1e-10});
    l.outputs.push_back(plant::SignalInfo{.name = "a", .unit = "1"});
    return l;
  }
  template <class S>
  int rhs(std::span<const S> x, std::span<const double>, std::span<S> f) const {
    f[0] = 1e6 * (x[1] - x[0]);
    f[1] = 1e6 * (x[0] - x[1]);
    return plant::kModelOk;
  }
  template <class S>
  int outputs(std::span<const S> x, std::span<const double>, std::span<S> y) const {
    y[0] = x[0];
    return plant::kModelOk;
  }
};

}  // namespace

TEST_CASE("a covariance definite but for rounding is widened a trillionth, not reset", "[ekf]") {
  const plant::AdModel<Equalising> model{Equalising{}};
  const std::vector<double> no_noise{0.0, 0.0};
  est::Ekf ekf(model, no_noise, 1, est::EkfOptions{});
  ekf.reset(std::vector<double>{1.0, 3.0}, std::vector<double>{1.0, 1.0});
  // Before: the health check failed, the prediction was thrown away (x and P of the step before
  // kept) and counted as a numerical reset.
  REQUIRE(ekf.predict({}, 1.0) == est::StepStatus::kOk);
  CHECK(ekf.counters().numerical_resets == 0);
  CHECK(ekf.covariance_jitters() == 1);
  CHECK(ekf.state()(0) == Approx(2.0).epsilon(1e-4));  // the prediction kept: equalised
  // Each variance 0.5, widened by at most a relative 1e-6.
  CHECK(ekf.covariance()(0, 0) == Approx(0.5).epsilon(1e-6));
  CHECK(ekf.covariance()(0, 1) == Approx(0.5).epsilon(1e-6));
}
