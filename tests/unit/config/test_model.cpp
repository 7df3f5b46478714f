// The model section and the estimator: names and values checked against the catalog, the rules
// between estimator, points and runtime, and many errors in one document.
#include <catch2/catch.hpp>
#include <cmath>
#include <stdexcept>

#include "config_test_support.hpp"
#include "plant_models/catalog.hpp"

namespace hvac_twin::config {
namespace {

using nlohmann::json;
using test::demo_json;
using test::load;
using test::load_json;
using test::require_single_error;

json& model(json& j) {
  return j["units"][0]["model"];
}
json& estimator(json& j) {
  return j["units"][0]["estimator"];
}

// The layout of a model of the real catalog with its default parameters.
plant::ModelLayout default_layout(std::string_view type) {
  for (const auto& schema : plant::model_schemas()) {
    if (schema.type != type) continue;
    plant::ParameterMap parameters;
    for (const auto& p : schema.parameters)
      parameters[p.name] = p.default_value;
    return schema.layout(parameters);
  }
  throw std::invalid_argument("no model " + std::string(type) + " in the catalog");
}

TEST_CASE("model type must be in the catalog, the message lists the known types", "[config]") {
  auto j = demo_json();
  model(j)["type"] = "zone";
  require_single_error(
      load_json(j), "/units/0/model/type",
      {"unknown model type \"zone\"", "did you mean \"zone_rc\"?", "known types: \"zone_rc\""});
  model(j)["type"] = "heat_pump";
  require_single_error(load_json(j), "/units/0/model/type",
                       {"unknown model type \"heat_pump\"", "known types: \"zone_rc\""});
  model(j).erase("type");
  require_single_error(load_json(j), "/units/0/model", {"missing required field \"type\""});
  j.erase("units");
  j["units"] = demo_json()["units"];
  j["units"][0].erase("model");
  require_single_error(load_json(j), "/units/0", {"missing required field \"model\""});
}

TEST_CASE("model parameters: known names, values inside their range", "[config]") {
  auto j = demo_json();
  model(j)["parameters"]["C_ari"] = 2e6;
  require_single_error(load_json(j), "/units/0/model/parameters/C_ari",
                       {"unknown parameter \"C_ari\" of model \"zone_rc\"",
                        "did you mean \"C_air\"?", "\"gain_fraction_air\""});
  j = demo_json();
  model(j)["parameters"]["hp_fraction_air"] = 1.5;
  require_single_error(load_json(j), "/units/0/model/parameters/hp_fraction_air",
                       {"expected a number in [0, 1] [1]; got 1.5"});
  model(j)["parameters"]["hp_fraction_air"] = "1";
  require_single_error(load_json(j), "/units/0/model/parameters/hp_fraction_air",
                       {"expected a number in [0, 1]", "got \"1\""});
  j = demo_json();
  model(j)["parameters"]["C_air"] = 5;
  require_single_error(load_json(j), "/units/0/model/parameters/C_air",
                       {"expected a number in [10000, 1e9] [J/K]; got 5"});
  j = demo_json();
  model(j)["parameters"] = json::array();
  require_single_error(load_json(j), "/units/0/model/parameters",
                       {"expected an object; got an array"});
  model(j).erase("parameters");
  const LoadResult r = load_json(j);
  test::require_ok(r);
  CHECK(r.config->units[0].model.parameters.empty());
}

TEST_CASE("an invalid parameter does not hide the errors of points and estimator", "[config]") {
  auto j = demo_json();
  model(j)["parameters"]["UA_air_out"] = -5;
  j["units"][0]["points"][0]["signal"] = "zone_air_temp";
  const LoadResult r = load_json(j);
  INFO(test::describe(r));
  CHECK(r.errors.size() == 2);
  CHECK(test::has_error(r, "/units/0/model/parameters/UA_air_out", {"got -5"}));
  CHECK(test::has_error(r, "/units/0/points/0/signal", {"unknown model output"}));
}

TEST_CASE("estimator maps name existing states with sane values", "[config]") {
  auto j = demo_json();
  estimator(j)["process_noise"]["Q_itn"] = 1.0;
  require_single_error(load_json(j), "/units/0/estimator/process_noise/Q_itn",
                       {"unknown state \"Q_itn\" of model \"zone_rc\"", "did you mean \"Q_int\"?",
                        R"("T_air", "T_mass", "Q_int")"});
  j = demo_json();
  estimator(j)["process_noise"]["Q_int"] = -1;
  require_single_error(load_json(j), "/units/0/estimator/process_noise/Q_int",
                       {"expected a number in [0, ", "[W/sqrt(s)]; got -1"});
  estimator(j)["process_noise"]["Q_int"] = 0;
  test::require_ok(load_json(j));

  j = demo_json();
  estimator(j)["initial_state"] = {{"T_air", 21.5}, {"T_mass", 100}};
  require_single_error(load_json(j), "/units/0/estimator/initial_state/T_mass",
                       {"expected a number in [-40, 70] [degC]; got 100"});
  j = demo_json();
  estimator(j)["initial_std"] = {{"T_air", 0}};
  require_single_error(load_json(j), "/units/0/estimator/initial_std/T_air",
                       {"expected a number in (0, 110] [degC]; got 0"});
  estimator(j)["initial_std"] = {{"T_air", 0.5}, {"Q_int", 100}};
  estimator(j)["initial_state"] = {{"T_air", 21.5}, {"Q_int", 500}};
  const LoadResult ok = load_json(j);
  test::require_ok(ok);
  CHECK(ok.config->units[0].estimator.initial_std.at("Q_int") == 100);
  CHECK(ok.config->units[0].estimator.initial_state.at("T_air") == 21.5);
  estimator(j)["initial_state"] = 5;
  require_single_error(load_json(j), "/units/0/estimator/initial_state",
                       {"expected an object; got 5"});
}

// 1e308 passed, and its square is an infinite covariance: a numerical reset every cycle.
TEST_CASE("initial_std and process_noise are bounded by the state's range", "[config]") {
  const plant::ModelLayout layout = default_layout("zone_rc");
  REQUIRE_FALSE(layout.states.empty());
  for (const auto& s : layout.states) {
    INFO("state " << s.name);
    const double width = s.max - s.min;
    REQUIRE(std::isfinite(width));
    const double q_max = width / std::sqrt(3600.0);  // an hour's random walk spans the range
    const std::string std_at = "/units/0/estimator/initial_std/" + s.name;
    const std::string q_at = "/units/0/estimator/process_noise/" + s.name;
    auto j = demo_json();
    estimator(j)["initial_std"] = {{s.name, width}};
    estimator(j)["process_noise"] = {{s.name, q_max}};
    test::require_ok(load_json(j));
    estimator(j)["initial_std"] = {{s.name, 1e308}};
    require_single_error(load_json(j), std_at, {"expected a number in (0, ", s.unit + "]"});
    estimator(j)["initial_std"] = {{s.name, width * (1.0 + 1e-9)}};
    require_single_error(load_json(j), std_at, {"expected a number in (0, "});
    estimator(j)["initial_std"] = {{s.name, width}};
    estimator(j)["process_noise"] = {{s.name, 1e308}};
    require_single_error(load_json(j), q_at, {"expected a number in [0, ", s.unit + "/sqrt(s)]"});
    estimator(j)["process_noise"] = {{s.name, q_max * (1.0 + 1e-9)}};
    require_single_error(load_json(j), q_at, {"expected a number in [0, "});
  }
  // The message gives the interval: T_air's range is [-40, 70] degC, 110 wide.
  auto j = demo_json();
  estimator(j)["initial_std"] = {{"T_air", 1e308}};
  require_single_error(load_json(j), "/units/0/estimator/initial_std/T_air",
                       {"expected a number in (0, 110] [degC]"});
}

TEST_CASE("every measured output has a measurement_noise entry with sigma > 0", "[config]") {
  auto j = demo_json();
  estimator(j)["measurement_noise"] = json::object();
  require_single_error(load_json(j), "/units/0/estimator/measurement_noise",
                       {"missing entry for measured output \"zone_air_temperature\"",
                        "point \"zone_temp\"", "[degC], > 0"});
  estimator(j)["measurement_noise"] = {{"zone_air_temperature", 0}};
  require_single_error(load_json(j), "/units/0/estimator/measurement_noise/zone_air_temperature",
                       {"expected a number > 0 [degC]; got 0"});
  estimator(j).erase("measurement_noise");
  require_single_error(load_json(j), "/units/0/estimator",
                       {"missing required field \"measurement_noise\""});
  j["units"][0].erase("estimator");
  require_single_error(load_json(j), "/units/0", {"missing required field \"estimator\""});
}

TEST_CASE("measurement_noise names only outputs that a point measures", "[config]") {
  auto j = demo_json();
  estimator(j)["measurement_noise"]["mass_temperature"] = 0.1;
  require_single_error(load_json(j), "/units/0/estimator/measurement_noise/mass_temperature",
                       {"output \"mass_temperature\" is not measured by any point"});
  j = demo_json();
  estimator(j)["measurement_noise"]["zone_temperature"] = 0.1;
  require_single_error(load_json(j), "/units/0/estimator/measurement_noise/zone_temperature",
                       {"unknown model output \"zone_temperature\""});
}

TEST_CASE("estimator period, deadline, gate and rejections", "[config]") {
  auto j = demo_json();
  estimator(j)["deadline_s"] = 1.5;  // wall period = 60 s / time_scale 60 = 1 s
  require_single_error(load_json(j), "/units/0/estimator/deadline_s",
                       {"deadline_s (1.5 s) must not exceed the wall-clock period period_s / "
                        "runtime.time_scale = 60 / 60 = 1 s"});
  estimator(j)["deadline_s"] = 1.0;
  test::require_ok(load_json(j));
  j["runtime"]["time_scale"] = 600;
  require_single_error(load_json(j), "/units/0/estimator/deadline_s", {"= 60 / 600 = 0.1 s"});
  j = demo_json();
  estimator(j)["deadline_s"] = 0;
  require_single_error(load_json(j), "/units/0/estimator/deadline_s",
                       {"expected a number in [1e-9, 3600] [s]; got 0"});
  j = demo_json();
  estimator(j)["period_s"] = -60;
  require_single_error(load_json(j), "/units/0/estimator/period_s", {"(0, 86400]", "got -60"});
  j = demo_json();
  estimator(j)["nis_gate"] = 0;
  require_single_error(load_json(j), "/units/0/estimator/nis_gate",
                       {"expected a number > 0; got 0"});
  j = demo_json();
  estimator(j)["robust_threshold"] = -1;
  require_single_error(load_json(j), "/units/0/estimator/robust_threshold",
                       {"expected a number >= 0; got -1"});
  j = demo_json();
  estimator(j)["robust_threshold"] = 0;  // off: every reading the gate lets in at full weight
  const LoadResult off = load_json(j);
  test::require_ok(off);
  CHECK(off.config->units[0].estimator.robust_threshold == 0.0);
  j = demo_json();
  estimator(j)["max_consecutive_rejections"] = 0;
  require_single_error(load_json(j), "/units/0/estimator/max_consecutive_rejections",
                       {"expected an integer in [1, 1000000]; got 0"});
  // An omitted deadline_s takes its default (1 s), too long at time_scale 120.
  j = demo_json();
  estimator(j).erase("deadline_s");
  j["runtime"]["time_scale"] = 120;
  require_single_error(load_json(j), "/units/0/estimator", {"deadline_s (1 s) must not exceed"});
}

// The runtime counts the wall-clock period and the deadline in whole nanoseconds, and DDS takes
// a period of at most 24 h: start-up refused (exit 1) what --check-config had passed.
TEST_CASE("the wall-clock period is 1 ns to 24 h, the deadline at least 1 ns", "[config]") {
  auto j = demo_json();
  estimator(j)["period_s"] = 1e-12;              // 1.7e-14 s of wall time at time_scale 60
  estimator(j)["deadline_s"] = 1e-15;            // within that period
  estimator(j)["consistency_window_s"] = 1e-10;  // 100 cycles
  const LoadResult r = load_json(j);
  INFO(test::describe(r));
  CHECK_FALSE(r.config.has_value());
  CHECK(r.errors.size() == 2);
  CHECK(test::has_error(r, "/units/0/estimator/period_s",
                        {"period_s / runtime.time_scale = 1e-12 / 60 = ", "[1e-9, 86400]"}));
  CHECK(test::has_error(r, "/units/0/estimator/deadline_s",
                        {"expected a number in [1e-9, 3600] [s]; got 1e-15"}));
  // Nanoseconds are enough.
  estimator(j)["period_s"] = 120e-9;  // 2 ns of wall time
  estimator(j)["deadline_s"] = 1e-9;
  estimator(j)["consistency_window_s"] = 120e-9 * 30;
  test::require_ok(load_json(j));

  j = demo_json();
  estimator(j)["period_s"] = 86400;
  j["runtime"]["time_scale"] = 0.5;
  require_single_error(load_json(j), "/units/0/estimator/period_s",
                       {"= 86400 / 0.5 = 172800 s", "[1e-9, 86400]"});
  j["runtime"]["time_scale"] = 1;
  test::require_ok(load_json(j));
}

TEST_CASE("every error of a document is reported, not just the first", "[config]") {
  auto j = demo_json();
  j["site_id"] = "demo site";
  j["units"][0]["modbus"]["port"] = 70000;
  j["units"][0]["points"][1]["type"] = "float";
  j["units"][0]["points"][2]["unit"] = "kPa";
  model(j)["parameters"]["C_mass"] = 0;
  estimator(j)["process_noise"]["T_ari"] = 1;
  j["dds"]["domain_id"] = 300;
  j["runtime"]["log_level"] = "loud";
  const LoadResult r = load_json(j);
  INFO(test::describe(r));
  CHECK_FALSE(r.config.has_value());
  std::vector<std::string> pointers;
  for (const auto& e : r.errors)
    pointers.push_back(e.pointer);
  // nlohmann::json writes keys sorted, so document order is alphabetical here.
  CHECK(pointers == std::vector<std::string>{
                        "/dds/domain_id",
                        "/runtime/log_level",
                        "/site_id",
                        "/units/0/estimator/process_noise/T_ari",
                        "/units/0/modbus/port",
                        "/units/0/model/parameters/C_mass",
                        "/units/0/points/1/type",
                        "/units/0/points/2/unit",
                    });
}

// A catalog with what zone_rc lacks: an integer (structural) parameter that sizes the state,
// and a layout function that throws.
ModelCatalog fake_catalog() {
  plant::ModelSchema cells;
  cells.type = "cells";
  cells.parameters = {{"n_cells", "1", 3.0, 1.0, 20.0, true, "number of cells"},
                      {"ua", "W/K", 10.0, 0.0, 100.0, false, "conductance"}};
  cells.layout = [](const plant::ParameterMap& p) {
    plant::ModelLayout l;
    for (int i = 0; i < static_cast<int>(p.at("n_cells")); ++i) {
      std::string name = "T";  // appended: GCC 12 warns (-Wrestrict) on "T" + string
      name += std::to_string(i);
      l.states.push_back({name, "degC"});
    }
    l.outputs.push_back({"T_out", "degC"});
    return l;
  };
  plant::ModelSchema broken = cells;
  broken.type = "broken";
  broken.layout = [](const plant::ParameterMap&) -> plant::ModelLayout {
    throw std::runtime_error("table file missing");
  };
  return {cells, broken};
}

// `more`: further members of the estimator, e.g. R"(, "initial_std": {"T0": 1})".
std::string cells_config(std::string_view type, std::string_view parameters,
                         std::string_view initial_state, std::string_view more = "") {
  return R"({"site_id": "s", "units": [{"id": "u",
    "model": {"type": ")" +
         std::string(type) + R"(", "parameters": )" + std::string(parameters) + R"(},
    "points": [{"name": "t", "address": 0, "unit": "degC", "range": [0, 100], "signal": "T_out"}],
    "estimator": {"measurement_noise": {"T_out": 0.1}, "initial_state": )" +
         std::string(initial_state) + std::string(more) + "}}]}";
}

TEST_CASE("integer parameters must be integral, structural ones size the layout", "[config]") {
  const ModelCatalog models = fake_catalog();
  const auto run = [&](std::string_view type, std::string_view params, std::string_view init) {
    return load_config_text(cells_config(type, params, init), models);
  };
  test::require_ok(run("cells", R"({"n_cells": 5})", R"({"T4": 20})"));
  require_single_error(run("cells", R"({"n_cells": 3})", R"({"T4": 20})"),
                       "/units/0/estimator/initial_state/T4",
                       {"unknown state \"T4\"", R"("T0", "T1", "T2")"});
  require_single_error(run("cells", R"({"n_cells": 2.5})", R"({"T4": 20})"),
                       "/units/0/model/parameters/n_cells",
                       {"expected an integer in [1, 20] [1]; got 2.5"});
  require_single_error(run("cells", R"({"n_cells": 5, "ua": 200})", R"({"T4": 20})"),
                       "/units/0/model/parameters/ua", {"expected a number in [0, 100]"});
  require_single_error(run("broken", "{}", "{}"), "/units/0/model/parameters",
                       {"model \"broken\" rejected these parameters: table file missing"});
}

// The fake catalog's states have no finite range: initial_std and process_noise are capped so
// that their squares stay finite.
TEST_CASE("initial_std and process_noise of a state without a finite range are capped",
          "[config]") {
  const ModelCatalog models = fake_catalog();
  const auto run = [&](std::string_view more) {
    return load_config_text(cells_config("cells", "{}", "{}", more), models);
  };
  test::require_ok(run(R"(, "initial_std": {"T0": 1e6}, "process_noise": {"T0": 1e6})"));
  require_single_error(run(R"(, "initial_std": {"T0": 1e308})"),
                       "/units/0/estimator/initial_std/T0",
                       {"expected a number in (0, 1e6] [degC]; got 1e308"});
  require_single_error(run(R"(, "process_noise": {"T1": 1e308})"),
                       "/units/0/estimator/process_noise/T1",
                       {"expected a number in [0, 1e6] [degC/sqrt(s)]; got 1e308"});
}

}  // namespace
}  // namespace hvac_twin::config
