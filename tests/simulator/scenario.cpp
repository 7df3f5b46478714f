#include "tests/simulator/scenario.hpp"

#include <stdexcept>
#include <string>

namespace hvac_twin::sim {

std::unique_ptr<Scenario> make_zone_scenario(const plant::ContinuousModel& model,
                                             const ScenarioOptions& options);
std::unique_ptr<Scenario> make_heat_pump_scenario(const plant::ContinuousModel& model,
                                                  const ScenarioOptions& options);

std::unique_ptr<Scenario> make_scenario(std::string_view model_type,
                                        const plant::ContinuousModel& model,
                                        const ScenarioOptions& options) {
  if (model_type == "zone_rc") return make_zone_scenario(model, options);
  if (model_type == "heat_pump_r32") return make_heat_pump_scenario(model, options);
  throw std::invalid_argument("no simulator scenario for model type \"" + std::string(model_type) +
                              "\"");
}

}  // namespace hvac_twin::sim
