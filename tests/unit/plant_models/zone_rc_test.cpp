#include "plant_models/zone/zone_rc.hpp"

#include <catch2/catch.hpp>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "finite_difference.hpp"
#include "plant_models/catalog.hpp"
#include "plant_models/core/ad_model.hpp"

using namespace hvac_twin::plant;

namespace {

std::vector<double> random_state(std::mt19937& rng) {
  std::uniform_real_distribution<double> temp(-10.0, 40.0), gains(0.0, 3000.0);
  std::vector<double> x(ZoneRc::kNumStates);
  x[ZoneRc::kTAir] = temp(rng);
  x[ZoneRc::kTMass] = temp(rng);
  x[ZoneRc::kQInt] = gains(rng);
  return x;
}

}  // namespace

TEST_CASE("zone_rc AD Jacobians equal finite differences at random states", "[zone_rc]") {
  ZoneRc::Params p;
  p.hp_fraction_air = 0.7;  // exercise every coupling term
  const AdModel<ZoneRc> model{ZoneRc(p)};
  const std::size_t n = model.num_states(), m = model.num_outputs();
  std::mt19937 rng(42);
  const std::vector<double> u{2500.0, -3.0};
  const std::vector<double> floor{1.0, 1.0, 100.0};
  double worst_f = 0.0, worst_h = 0.0;
  for (int trial = 0; trial < 100; ++trial) {
    const auto x = random_state(rng);
    std::vector<double> jac(n * n), xdot(n), hjac(m * n), y(m);
    REQUIRE(model.rhs_jacobian(x, u, xdot, jac) == kModelOk);
    REQUIRE(model.output_jacobian(x, u, y, hjac) == kModelOk);
    const auto fd_f = hvac_twin::test::central_jacobian(
        [&](std::span<const double> xs, std::span<double> out) { model.rhs(xs, u, out); }, x, n,
        floor);
    const auto fd_h = hvac_twin::test::central_jacobian(
        [&](std::span<const double> xs, std::span<double> out) { model.outputs(xs, u, out); }, x, m,
        floor);
    worst_f = std::max(worst_f, hvac_twin::test::max_rel_error(jac, fd_f, 1e-9));
    worst_h = std::max(worst_h, hvac_twin::test::max_rel_error(hjac, fd_h, 1e-9));
    // The value returned with the Jacobian is the plain evaluation.
    std::vector<double> plain(n);
    model.rhs(x, u, plain);
    for (std::size_t i = 0; i < n; ++i)
      CHECK(xdot[i] == Approx(plain[i]));
  }
  INFO("largest relative error, f: " << worst_f << ", h: " << worst_h);
  CHECK(worst_f < 1e-6);
  CHECK(worst_h < 1e-6);
}

TEST_CASE("zone_rc conserves energy", "[zone_rc]") {
  ZoneRc::Params p;
  p.hp_fraction_air = 0.8;
  p.gain_fraction_air = 0.4;
  const ZoneRc zone(p);
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    const auto x = random_state(rng);
    const std::vector<double> u{std::uniform_real_distribution<double>(-5000, 5000)(rng),
                                std::uniform_real_distribution<double>(-20, 35)(rng)};
    std::vector<double> xdot(ZoneRc::kNumStates), y(ZoneRc::kNumOutputs);
    REQUIRE(zone.rhs<double>(x, u, xdot) == kModelOk);
    REQUIRE(zone.outputs<double>(x, u, y) == kModelOk);
    const double stored = p.c_air * xdot[ZoneRc::kTAir] + p.c_mass * xdot[ZoneRc::kTMass];
    const double supplied = u[ZoneRc::kQHp] + x[ZoneRc::kQInt] - y[ZoneRc::kEnvelopeHeatLoss];
    CHECK(stored == Approx(supplied).margin(1e-9));
    CHECK(xdot[ZoneRc::kQInt] == 0.0);
  }
}

TEST_CASE("zone_rc is in the catalog with consistent parameters and layout", "[zone_rc]") {
  const ModelSchema* schema = find_schema("zone_rc");
  REQUIRE(schema != nullptr);
  REQUIRE(find_schema("no_such_model") == nullptr);
  const ParameterMap full = with_defaults(*schema, {{"C_air", 5e6}});
  CHECK(full.size() == schema->parameters.size());
  CHECK(full.at("C_air") == 5e6);
  for (const auto& info : schema->parameters) {
    CHECK(info.default_value >= info.min);
    CHECK(info.default_value <= info.max);
    CHECK_FALSE(info.unit.empty());
  }
  const ModelLayout layout = schema->layout(full);
  CHECK(layout.states.size() == ZoneRc::kNumStates);
  CHECK(layout.inputs.size() == ZoneRc::kNumInputs);
  CHECK(layout.outputs.size() == ZoneRc::kNumOutputs);
  std::set<std::string> names;
  for (const auto& s : layout.states)
    names.insert(s.name);
  for (const auto& s : layout.inputs)
    names.insert(s.name);
  for (const auto& s : layout.outputs)
    names.insert(s.name);
  CHECK(names.size() == layout.states.size() + layout.inputs.size() + layout.outputs.size());
  for (const auto& s : layout.states) {
    CHECK(s.initial >= s.min);
    CHECK(s.initial <= s.max);
    CHECK(s.initial_std > 0.0);
  }
  // The parameter map reaches the model.
  const auto model = create_model("zone_rc", {{"C_air", 5e6}});
  const auto& zone = dynamic_cast<const AdModel<ZoneRc>&>(*model).model();
  CHECK(zone.params().c_air == 5e6);
  CHECK(zone.params().c_mass == ZoneRc::Params{}.c_mass);
  CHECK_THROWS_AS(create_model("nope", {}), std::invalid_argument);
}
