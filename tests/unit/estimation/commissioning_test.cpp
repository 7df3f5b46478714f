// est::StatePhases: which states a filter estimates while it settles, while it is commissioned
// with a known charge, and in operation; and that commissioning starts from the known value.
#include "daemon/estimation/commissioning.hpp"

#include <catch2/catch.hpp>
#include <cmath>
#include <vector>

#include "daemon/estimation/ekf.hpp"
#include "plant_models/core/ad_model.hpp"

using namespace hvac_twin;

namespace {

// x physical; a an augmented parameter; v an augmented closure to calibrate; m the known
// "charge" (augmented). All constant; y = x + a + v + m.
struct Phased {
  plant::ModelLayout layout() const {
    plant::ModelLayout l;
    l.states.push_back(plant::StateInfo{.name = "x", .unit = "1", .abs_tol = 1e-10});
    // a: revealed only while input "speed" is at least 5 (the compressor running).
    l.states.push_back(plant::StateInfo{.name = "a",
                                        .unit = "1",
                                        .abs_tol = 1e-10,
                                        .augmented = true,
                                        .excited_by = 0,
                                        .excitation_min = 5.0});
    l.states.push_back(plant::StateInfo{
        .name = "v", .unit = "1", .abs_tol = 1e-10, .augmented = true, .calibrate = true});
    l.states.push_back(
        plant::StateInfo{.name = "m", .unit = "kg", .abs_tol = 1e-10, .augmented = true});
    l.inputs.push_back(plant::SignalInfo{.name = "speed", .unit = "Hz", .default_value = 0.0});
    l.outputs.push_back(plant::SignalInfo{.name = "y", .unit = "1"});
    return l;
  }
  template <class S>
  int rhs(std::span<const S>, std::span<const double>, std::span<S> f) const {
    for (auto& v : f)
      v = S(0.0);
    return plant::kModelOk;
  }
  template <class S>
  int outputs(std::span<const S> x, std::span<const double>, std::span<S> y) const {
    y[0] = x[0] + x[1] + x[2] + x[3];
    return plant::kModelOk;
  }
};

std::vector<bool> flags(const est::Estimator& f) {
  std::vector<bool> c;
  for (std::size_t i = 0; i < f.num_states(); ++i)
    c.push_back(f.considered(i));
  return c;
}

}  // namespace

TEST_CASE("state phases: settle, commission with the charge known, operate",
          "[commissioning][ekf]") {
  const plant::AdModel<Phased> model(Phased{});
  est::Ekf ekf(model, std::vector<double>(4, 0.0), 1, est::EkfOptions{});
  ekf.reset(std::vector<double>{1.0, 0.0, 0.0, 0.45}, std::vector<double>{0.1, 0.2, 0.3, 0.05});
  est::StatePhases phases(model.layout(), {{"m", 0.5, 0.005}}, 600.0, 3600.0);
  REQUIRE(phases.begin(ekf, 0.0).empty());
  // The known charge at its value and sigma, uncorrelated; the rest untouched.
  CHECK(ekf.state()(3) == 0.5);
  CHECK(ekf.covariance()(3, 3) == Approx(0.005 * 0.005));
  CHECK(ekf.state()(0) == 1.0);
  CHECK(ekf.covariance()(0, 0) == Approx(0.01));
  // Settling: every augmented state held, the physical one estimated.
  CHECK(flags(ekf) == std::vector<bool>{false, true, true, true});
  // Commissioning: the closure calibrated, the known charge held, the parameter estimated.
  phases.apply(ekf, 600.0);
  CHECK(flags(ekf) == std::vector<bool>{false, false, false, true});
  // Operation: the closure frozen (considered), the charge estimated again.
  phases.apply(ekf, 3600.0);
  CHECK(flags(ekf) == std::vector<bool>{false, false, true, false});
  // The configuration may estimate the closure in operation too.
  phases.set_base(2, false);
  phases.apply(ekf, 7200.0);
  CHECK(flags(ekf) == std::vector<bool>{false, false, false, false});
}

TEST_CASE("state phases: without commissioning a closure is considered from the settle on",
          "[commissioning][ekf]") {
  const plant::AdModel<Phased> model(Phased{});
  est::Ekf ekf(model, std::vector<double>(4, 0.0), 1, est::EkfOptions{});
  ekf.reset(std::vector<double>{1.0, 0.0, 0.0, 0.45}, std::vector<double>{0.1, 0.2, 0.3, 0.05});
  est::StatePhases phases(model.layout(), {}, 600.0, 3600.0);
  REQUIRE(phases.begin(ekf, 0.0).empty());
  CHECK(ekf.state()(3) == 0.45);
  phases.apply(ekf, 700.0);
  CHECK(flags(ekf) == std::vector<bool>{false, false, true, false});
}

TEST_CASE("state phases: a restart after commissioning keeps the estimate, and bad input is named",
          "[commissioning][ekf]") {
  const plant::AdModel<Phased> model(Phased{});
  est::Ekf ekf(model, std::vector<double>(4, 0.0), 1, est::EkfOptions{});
  ekf.reset(std::vector<double>{1.0, 0.0, 0.0, 0.45}, std::vector<double>{0.1, 0.2, 0.3, 0.05});
  est::StatePhases late(model.layout(), {{"m", 0.5, 0.005}}, 600.0, 3600.0);
  REQUIRE(late.begin(ekf, 4000.0).empty());
  CHECK(ekf.state()(3) == 0.45);  // the estimate carried over, not the weighed-in value
  CHECK(flags(ekf) == std::vector<bool>{false, false, true, false});

  est::StatePhases unknown(model.layout(), {{"charge", 0.5, 0.005}}, 600.0, 3600.0);
  CHECK(unknown.begin(ekf, 0.0) == "commissioning: the model has no state \"charge\"");
  est::StatePhases no_sigma(model.layout(), {{"m", 0.5, 0.0}}, 600.0, 3600.0);
  CHECK(no_sigma.begin(ekf, 0.0).find("sigma > 0") != std::string::npos);
  CHECK(ekf.state()(3) == 0.45);  // unchanged by the refused begin()s
}

TEST_CASE("state phases: a parameter only a running process reveals is held while it stands",
          "[commissioning][ekf]") {
  const plant::AdModel<Phased> model(Phased{});
  est::Ekf ekf(model, std::vector<double>(4, 0.0), 1, est::EkfOptions{});
  ekf.reset(std::vector<double>{1.0, 0.0, 0.0, 0.45}, std::vector<double>{0.1, 0.2, 0.3, 0.05});
  const est::StatePhases phases(model.layout(), {}, 600.0, 0.0);
  const std::vector<double> stopped{0.0}, running{20.0}, unknown{std::nan("")};
  phases.apply(ekf, 700.0, running);
  CHECK(flags(ekf) == std::vector<bool>{false, false, true, false});
  phases.apply(ekf, 700.0, stopped);  // below excitation_min: held, the rest as before
  CHECK(flags(ekf) == std::vector<bool>{false, true, true, false});
  phases.apply(ekf, 700.0, unknown);  // an input not known is no excitation
  CHECK(flags(ekf) == std::vector<bool>{false, true, true, false});
  phases.apply(ekf, 700.0, running);  // released when the process runs again
  CHECK(flags(ekf) == std::vector<bool>{false, false, true, false});

  // Held, the update leaves it where it was while the others move.
  phases.apply(ekf, 700.0, stopped);
  std::vector<est::MeasurementReport> reports(1);
  const std::vector<est::Measurement> z{
      {.output = 0, .value = 2.0, .variance = 0.01, .available = true}};
  const double a0 = ekf.state()(1);
  REQUIRE(ekf.update(z, stopped, reports) == est::StepStatus::kOk);
  CHECK(ekf.state()(1) == a0);
  CHECK(ekf.state()(0) != 1.0);
}

TEST_CASE("state phases: the filter is starting while the parameters' gain ramps up",
          "[commissioning][ekf]") {
  const plant::AdModel<Phased> model(Phased{});
  est::Ekf ekf(model, std::vector<double>(4, 0.0), 1, est::EkfOptions{});
  ekf.reset(std::vector<double>{1.0, 0.0, 0.0, 0.45}, std::vector<double>{0.1, 0.2, 0.3, 0.05});
  est::StatePhases phases(model.layout(), {}, 600.0, 0.0, 120.0);
  REQUIRE(phases.begin(ekf, 0.0).empty());
  CHECK_FALSE(ekf.starting());  // the hold: the parameters cannot fit a sensor yet
  phases.apply(ekf, 599.0);
  CHECK_FALSE(ekf.starting());
  phases.apply(ekf, 600.0);
  CHECK(ekf.starting());
  CHECK(ekf.gain_weight(1) == 0.0);
  phases.apply(ekf, 700.0);
  CHECK(ekf.starting());
  phases.apply(ekf, 720.0);
  CHECK_FALSE(ekf.starting());
  CHECK(ekf.gain_weight(1) == 1.0);
  // Released at once (no ramp): never starting.
  est::StatePhases at_once(model.layout(), {}, 600.0, 0.0, 0.0);
  at_once.apply(ekf, 600.0);
  CHECK_FALSE(ekf.starting());
}
