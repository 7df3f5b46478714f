// A unit whose model is an FMU (model.type "fmu"): the configuration is checked against the
// FMU's own description (parameters, states, inputs, outputs), and every error names its JSON
// pointer. Uses the exported zone FMU and the demo configuration.
#include <catch2/catch.hpp>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "config/load.hpp"
#include "io/fmi/import/fmu_schema.hpp"
#include "plant_models/catalog.hpp"
#include "tests/support/edited_fmu.hpp"
#include "tests/support/scratch_dir.hpp"
#include "tests/unit/config/config_test_support.hpp"

using namespace hvac_twin;
using config::test::describe;
using config::test::has_error;

namespace {

std::string fmu_path(const std::string& model) {
  return std::string(HVAC_TWIN_BINARY_DIR) + "/fmu/" + model + ".fmu";
}

config::LoadResult load_with_fmu(const nlohmann::json& document) {
  config::ModelCatalog catalog = plant::model_schemas();
  catalog.push_back(fmi::fmu_schema());
  return config::load_config_text(document.dump(), catalog);
}

// The demo configuration with its zone model taken from `file`.
nlohmann::json demo_on(const std::string& file) {
  auto c = config::test::demo_json();
  auto& model = c["units"][0]["model"];
  model["type"] = "fmu";
  model["fmu"] = file;
  return c;
}

}  // namespace

TEST_CASE("the demo configuration runs on the zone FMU: its parameters, states and signals",
          "[fmi][config]") {
  const auto r = load_with_fmu(demo_on(fmu_path("zone_rc")));
  INFO(describe(r));
  REQUIRE(r.config);
  const auto& model = r.config->units[0].model;
  CHECK(model.type == "fmu");
  CHECK(model.file == fmu_path("zone_rc"));
  CHECK(model.parameters.at("C_air") == 2.0e6);  // the demo's parameters are the FMU's
  // The catalog without "fmu" does not know the type (the daemon's includes it).
  CHECK(has_error(config::test::load_json(demo_on(fmu_path("zone_rc"))), "/units/0/model/type",
                  {"unknown model type \"fmu\""}));
}

TEST_CASE("an FMU model's file errors name /units/N/model/fmu", "[fmi][config]") {
  auto c = demo_on(fmu_path("zone_rc"));
  c["units"][0]["model"].erase("fmu");
  auto r = load_with_fmu(c);
  CHECK(has_error(r, "/units/0/model", {"missing required field \"fmu\""}));

  r = load_with_fmu(demo_on("fmu/zone_rc.fmu"));
  CHECK(has_error(r, "/units/0/model/fmu",
                  {"expected the FMU's absolute path; got \"fmu/zone_rc.fmu\""}));

  r = load_with_fmu(demo_on("/nonexistent/zone.fmu"));
  CHECK(has_error(r, "/units/0/model/fmu", {"/nonexistent/zone.fmu: no such file"}));

  r = load_with_fmu(demo_on(std::string(HVAC_TWIN_SOURCE_DIR) + "/config/demo.json"));
  CHECK(has_error(r, "/units/0/model/fmu", {"cannot open as an FMU (zip archive)"}));

  c = config::test::demo_json();
  c["units"][0]["model"]["fmu"] = fmu_path("zone_rc");
  r = load_with_fmu(c);
  CHECK(has_error(r, "/units/0/model/fmu", {"model type \"zone_rc\" is built in"}));
}

TEST_CASE("a configuration is checked against the FMU's own variables", "[fmi][config]") {
  auto c = demo_on(fmu_path("zone_rc"));
  c["units"][0]["model"]["parameters"]["C_airr"] = 1e6;
  c["units"][0]["model"]["parameters"]["C_air"] = -5.0;
  auto r = load_with_fmu(c);
  INFO(describe(r));
  CHECK(has_error(r, "/units/0/model/parameters/C_airr",
                  {"unknown parameter \"C_airr\"", "did you mean \"C_air\""}));
  CHECK(has_error(r, "/units/0/model/parameters/C_air", {"expected a number"}));

  // The heat pump's FMU has no heat_pump_heat input: the demo's point is refused by name, with
  // the FMU's inputs listed, as for a built-in model.
  c = demo_on(fmu_path("heat_pump_r32"));
  c["units"][0]["model"].erase("parameters");
  r = load_with_fmu(c);
  INFO(describe(r));
  CHECK_FALSE(r.config);
  CHECK(has_error(r, "/units/0/points/2/signal",
                  {"unknown model input \"heat_pump_heat\"", "\"compressor_speed\""}));
}

TEST_CASE("augment_<input> adds the FMU input's disturbance state to what the estimator may set",
          "[fmi][config]") {
  auto c = demo_on(fmu_path("zone_rc"));
  c["units"][0]["estimator"]["process_noise"]["heat_pump_heat_disturbance"] = 2.0;
  auto r = load_with_fmu(c);
  CHECK(has_error(r, "/units/0/estimator/process_noise/heat_pump_heat_disturbance",
                  {"heat_pump_heat_disturbance"}));
  c["units"][0]["model"]["parameters"]["augment_heat_pump_heat"] = 1;
  r = load_with_fmu(c);
  INFO(describe(r));
  REQUIRE(r.config);
  CHECK(r.config->units[0].model.parameters.at("augment_heat_pump_heat") == 1.0);
  c["units"][0]["model"]["parameters"]["augment_heat_pump_heat"] = 0.5;
  CHECK(has_error(load_with_fmu(c), "/units/0/model/parameters/augment_heat_pump_heat",
                  {"expected an integer"}));
}

TEST_CASE("an FMU with more states than the filters take is refused at its model",
          "[fmi][config]") {
  // A description with 1001 states (x_k' = -x_k), packed with the zone FMU's binary: validation
  // reads only the description.
  std::string xml =
      "<?xml version=\"1.0\"?>\n<fmiModelDescription fmiVersion=\"2.0\" modelName=\"big\" "
      "guid=\"{1}\" numberOfEventIndicators=\"0\">\n<ModelExchange modelIdentifier=\"zone_rc\"/>\n"
      "<ModelVariables>\n";
  const int n = 1001;
  for (int k = 0; k < n; ++k)
    xml += "<ScalarVariable name=\"x" + std::to_string(k) + "\" valueReference=\"" +
           std::to_string(k) + "\"><Real start=\"1\"/></ScalarVariable>\n";
  for (int k = 0; k < n; ++k)
    xml += "<ScalarVariable name=\"der(x" + std::to_string(k) + ")\" valueReference=\"" +
           std::to_string(n + k) + "\"><Real derivative=\"" + std::to_string(k + 1) +
           "\"/></ScalarVariable>\n";
  xml += "</ModelVariables>\n<ModelStructure><Derivatives>\n";
  for (int k = 0; k < n; ++k)
    xml += "<Unknown index=\"" + std::to_string(n + k + 1) + "\"/>\n";
  xml += "</Derivatives></ModelStructure>\n</fmiModelDescription>\n";
  const test::ScratchDir dir("fmu-big");
  test::write_zip(dir / "big.fmu", {{"modelDescription.xml", xml},
                                    {"binaries/linux64/zone_rc.so", test::zone_fmu_binary()}});
  auto c = demo_on(dir / "big.fmu");
  c["units"][0]["model"].erase("parameters");
  const auto r = load_with_fmu(c);
  CHECK(has_error(r, "/units/0/model", {"the model has 1001 states", "at most 1000"}));
}
