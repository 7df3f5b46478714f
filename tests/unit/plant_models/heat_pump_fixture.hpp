// Shared set-up for the heat-pump tests: the model from the catalog, the nominal inputs, and
// integration to an operating point.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "plant_models/catalog.hpp"
#include "plant_models/core/ad_model.hpp"
#include "plant_models/core/integrator.hpp"
#include "plant_models/heat_pump/heat_pump.hpp"

namespace hvac_twin::test {

// Rated speed, the valve opening that gives ~6 K superheat at 35/27 degC, rated fans.
inline std::vector<double> nominal_inputs(double t_out = 35.0) {
  return {50.0, 0.374, 1.0, 1.0, t_out};
}

// The structure the demo runs (config/demo-heat-pump.json) and the build exports the heat-pump
// FMU with (io/fmi/CMakeLists.txt): the seven closures it estimates carried as states.
inline plant::ParameterMap demo_structure() {
  plant::ParameterMap p;
  for (const char* factor :
       {"fouling", "evap_ua_factor", "comp_flow_factor", "comp_efficiency_factor", "void_exponent",
        "cond_htc_factor", "evap_htc_factor"})
    p[std::string("augment_") + factor] = 1.0;
  return p;
}

struct HeatPumpRig {
  std::unique_ptr<plant::ContinuousModel> model;
  const plant::HeatPumpR32* hp = nullptr;

  explicit HeatPumpRig(const plant::ParameterMap& params = {})
      : model(plant::create_model("heat_pump_r32", params)),
        hp(&dynamic_cast<const plant::AdModel<plant::HeatPumpR32>&>(*model).model()) {}

  // A zone that holds its temperature (huge heat capacities), for steady-state tests.
  static plant::ParameterMap pinned_zone(plant::ParameterMap p = {}) {
    p["zone_C_air"] = 1e9;
    p["zone_C_mass"] = 1e10;
    return p;
  }

  std::vector<double> start(double t_out = 35.0, double t_zone = 27.0, double charge = 0.5) const {
    return hp->initial_state(t_out, t_zone, charge);
  }

  // Integrates x over `seconds` in steps of `dt`; throws if the integrator fails.
  void run(std::vector<double>& x, const std::vector<double>& u, double seconds,
           double dt = 60.0) const {
    plant::Integrator integ(*model, plant::IntegratorOptions{});
    for (double t = 0.0; t < seconds - 1e-9; t += dt)
      if (!integ.step(x, u, std::min(dt, seconds - t), {}).ok())
        throw std::runtime_error(std::string("integration failed: ") + integ.last_error());
  }

  std::vector<double> outputs(const std::vector<double>& x, const std::vector<double>& u) const {
    std::vector<double> y(model->num_outputs());
    if (model->outputs(x, u, y) != plant::kModelOk) throw std::runtime_error("outputs failed");
    return y;
  }
};

}  // namespace hvac_twin::test
