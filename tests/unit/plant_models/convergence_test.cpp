// The heat-pump model converges in its cell count: at the cell count the daemon runs by default
// its steady answers are within the aims of the continuous (cell-free) reference at part load,
// nominal and full load (tests/support/heat_pump_steady.hpp; the full table is
// convergence_bench's). Fails if the default model drifts beyond the aims.
#include <catch2/catch.hpp>
#include <cmath>

#include "plant_models/catalog.hpp"
#include "tests/support/heat_pump_steady.hpp"

using namespace hvac_twin;

TEST_CASE("at its default cell count the heat pump is within the aims of its converged answer",
          "[heat_pump][convergence]") {
  const plant::ParameterMap defaults{};
  const plant::ModelSchema* schema = plant::find_schema("heat_pump_r32");
  REQUIRE(schema != nullptr);
  const int cells = static_cast<int>(plant::with_defaults(*schema, defaults).at("cells"));
  const double nameplate = 0.5;
  for (const test::OperatingPoint& op : test::kConvergencePoints) {
    INFO(op.name << ", " << cells << " cells");
    const test::SteadyAnswer ref = test::continuous_steady(defaults, op, nameplate);
    const test::SteadyAnswer a = test::model_steady(defaults, cells, op, nameplate);
    CHECK(a.subcooling == Approx(ref.subcooling).margin(0.3));
    CHECK(a.superheat == Approx(ref.superheat).margin(0.3));
    CHECK(a.tw_cond_in == Approx(ref.tw_cond_in).margin(0.3));
    CHECK(a.tw_cond_out == Approx(ref.tw_cond_out).margin(0.3));
    CHECK(a.tw_evap_in == Approx(ref.tw_evap_in).margin(0.3));
    CHECK(a.tw_evap_out == Approx(ref.tw_evap_out).margin(0.3));
    CHECK(a.q_cond == Approx(ref.q_cond).epsilon(0.01));
    CHECK(a.q_evap == Approx(ref.q_evap).epsilon(0.01));
    CHECK(a.p_discharge == Approx(ref.p_discharge).epsilon(0.005));
    CHECK(a.p_suction == Approx(ref.p_suction).epsilon(0.005));
    // The charge at which the model shows the reference's subcooling: within 1 % of nameplate.
    const double charge = test::model_charge_for_subcooling(defaults, cells, op, ref.subcooling);
    CHECK(charge == Approx(nameplate).margin(0.01 * nameplate));
  }
}

TEST_CASE("the first-order answer the profiles replace is far from the converged one",
          "[heat_pump][convergence]") {
  // The reference itself is what the test above measures against: it must not be a copy of the
  // model. At 4 cells the model is visibly off (subcooling 0.75 K and superheat 0.4 K from the
  // reference at the nominal point), and the reference agrees with the model at 40 cells to a
  // few hundredths of a kelvin.
  const plant::ParameterMap defaults{};
  const test::OperatingPoint& op = test::kConvergencePoints[1];
  const test::SteadyAnswer ref = test::continuous_steady(defaults, op, 0.5);
  const test::SteadyAnswer coarse = test::model_steady(defaults, 4, op, 0.5);
  const test::SteadyAnswer fine = test::model_steady(defaults, 40, op, 0.5);
  CHECK(std::abs(coarse.subcooling - ref.subcooling) > 0.5);
  CHECK(std::abs(coarse.superheat - ref.superheat) > 0.2);
  CHECK(fine.superheat == Approx(ref.superheat).margin(0.05));
  CHECK(fine.subcooling == Approx(ref.subcooling).margin(0.02));
  CHECK(fine.q_cond == Approx(ref.q_cond).epsilon(2e-4));
}

TEST_CASE("the end-wall states settle where the lag-free end formula puts the sensors",
          "[heat_pump][convergence]") {
  // The end walls change the sensors' motion, not their steady readings: each settles in its
  // own balance with the refrigerant and the air at its end, which is what the formula they
  // replace (the end cell's wall plus the steady end-versus-mean difference) reads at rest.
  // A rate or a conductance wrong by a factor would still settle there; a wrong reference
  // temperature or air side would not.
  for (const test::OperatingPoint& op : test::kConvergencePoints) {
    INFO(op.name);
    const test::SteadyAnswer walls = test::model_steady({{"end_walls", 1}}, 12, op, 0.5);
    const test::SteadyAnswer lumped = test::model_steady({{"end_walls", 0}}, 12, op, 0.5);
    CHECK(walls.tw_cond_in == Approx(lumped.tw_cond_in).margin(1e-3));
    CHECK(walls.tw_cond_out == Approx(lumped.tw_cond_out).margin(1e-3));
    CHECK(walls.tw_evap_in == Approx(lumped.tw_evap_in).margin(1e-3));
    CHECK(walls.tw_evap_out == Approx(lumped.tw_evap_out).margin(1e-3));
    CHECK(walls.subcooling == Approx(lumped.subcooling).margin(1e-4));
  }
}

TEST_CASE("with end-wall states the sensors' motion converges in the cell count",
          "[heat_pump][convergence]") {
  // convergence_bench's transient (the valve hunting, then a speed step) at the flooded 20 Hz
  // point: the condenser-inlet wall's motion at 12 cells against 40. With the lag-free end
  // formula it was 0.53 K RMS off, 2.6x its sensor's noise; with the end walls 0.08 K.
  const test::OperatingPoint flooded{"20 Hz flooded", 20.0, 0.27, 35.0, 27.0};
  const auto rms_against_40 = [&](double end_walls) {
    const plant::ParameterMap p{{"end_walls", end_walls}};
    const auto coarse = test::model_transient(p, 12, flooded, 0.5);
    const auto fine = test::model_transient(p, 40, flooded, 0.5);
    return test::motion_error(coarse, fine, 2).rms;  // the condenser-inlet wall
  };
  const double with_walls = rms_against_40(1);
  const double lag_free = rms_against_40(0);
  INFO("condenser-inlet wall's motion, RMS against 40 cells: " << with_walls << " K with end "
                                                               << "walls, " << lag_free
                                                               << " K without");
  CHECK(with_walls < 0.2);
  CHECK(lag_free > 2.0 * with_walls);
}
