// The demo configuration, the documented defaults, the reference documentation and the invalid
// example file.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "config/detail/reader.hpp"
#include "config/units.hpp"
#include "config_test_support.hpp"
#include "plant_models/catalog.hpp"

namespace hvac_twin::config {
namespace {

using test::load;
using test::load_json;
using test::read_repo_file;

std::string num(double v) {
  return detail::format_number(v);
}

std::string range_text(double lo, double hi) {
  const auto end = [](double v) { return std::isinf(v) ? (v < 0 ? "-inf" : "inf") : num(v); };
  std::string out = "[";  // appended piecewise: GCC 12 warns (-Wrestrict) on "[" + string
  out += end(lo);
  out += ", ";
  out += end(hi);
  out += "]";
  return out;
}

// The reference section of one model type, as config/README.md must contain it verbatim.
std::string model_reference(const plant::ModelSchema& schema) {
  const plant::ModelLayout layout =
      schema.layout(plant::with_defaults(schema, plant::ParameterMap{}));
  std::string md = "### `" + schema.type + "`\n\n" + schema.description + ".\n\n";
  md += "Parameters (`model.parameters`):\n\n";
  md += "| name | unit | default | range | description |\n|---|---|---|---|---|\n";
  for (const auto& p : schema.parameters)
    md += "| `" + p.name + "` | " + p.unit + " | " + num(p.default_value) + " | " +
          range_text(p.min, p.max) + (p.integer ? " integer" : "") + " | " + p.description + " |\n";
  md += "\nStates (keys of `estimator.process_noise`, `initial_state`, `initial_std`):\n\n";
  md +=
      "| name | unit | bounds | initial | initial_std | process_noise [unit/sqrt(s)] | "
      "description |\n|---|---|---|---|---|---|---|\n";
  for (const auto& s : layout.states)
    md += "| `" + s.name + "` | " + s.unit + " | " + range_text(s.min, s.max) + " | " +
          num(s.initial) + " | " + num(s.initial_std) + " | " + num(s.process_noise) + " | " +
          s.description + (s.augmented ? " (augmented)" : "") + " |\n";
  md += "\nInputs (`signal` of points with role `input` or `disturbance`):\n\n";
  md += "| name | unit | range | default | description |\n|---|---|---|---|---|\n";
  for (const auto& s : layout.inputs)
    md += "| `" + s.name + "` | " + s.unit + " | " + range_text(s.min, s.max) + " | " +
          (std::isnan(s.default_value) ? std::string("required") : num(s.default_value)) + " | " +
          s.description + " |\n";
  md +=
      "\nOutputs (`signal` of points with role `measured`; keys of "
      "`estimator.measurement_noise`):\n\n";
  md += "| name | unit | range | description |\n|---|---|---|---|\n";
  for (const auto& s : layout.outputs)
    md += "| `" + s.name + "` | " + s.unit + " | " + range_text(s.min, s.max) + " | " +
          s.description + " |\n";
  return md;
}

TEST_CASE("demo.json loads with the values it sets and the documented defaults", "[config]") {
  const LoadResult r = load(read_repo_file("config/demo.json"));
  test::require_ok(r);
  const Config& c = *r.config;
  CHECK(c.site_id == "demo-site");
  CHECK(c.state_directory == "demo-state");
  REQUIRE(c.units.size() == 1);
  const UnitConfig& u = c.units[0];
  CHECK(u.id == "zone1");
  CHECK(u.modbus.host == "127.0.0.1");
  CHECK(u.modbus.port == 15020);
  CHECK(u.modbus.unit_id == 1);
  CHECK(u.modbus.poll_period_s == 0.25);
  CHECK(u.modbus.response_timeout_s == 0.1);
  CHECK(u.modbus.byte_timeout_s == 0.05);
  CHECK(u.modbus.max_registers_per_request == 125);

  REQUIRE(u.points.size() == 3);
  const PointConfig& zone = u.points[0];
  CHECK(zone.name == "zone_temp");
  CHECK(zone.kind == RegisterKind::kInput);
  CHECK(zone.address == 0);
  CHECK(zone.type == ValueType::kInt16);
  CHECK(zone.word_order == WordOrder::kABCD);  // default
  CHECK(zone.scale == 0.01);
  CHECK(zone.offset == 0.0);  // default
  CHECK(zone.unit == "degC");
  CHECK(zone.range_min == -20.0);
  CHECK(zone.range_max == 50.0);
  CHECK(zone.stale_after_s == 2.0);
  CHECK(zone.role == PointRole::kMeasured);
  CHECK(zone.signal == "zone_air_temperature");
  const PointConfig& outdoor = u.points[1];
  CHECK(outdoor.address == 1);
  CHECK(outdoor.scale == 0.1);
  CHECK(outdoor.stale_after_s == 10.0);  // default
  CHECK(outdoor.role == PointRole::kDisturbance);
  CHECK(outdoor.signal == "outdoor_temperature");
  const PointConfig& hp = u.points[2];
  CHECK(hp.address == 2);
  CHECK(hp.type == ValueType::kFloat32);
  CHECK(hp.word_order == WordOrder::kCDAB);
  CHECK(hp.scale == 1.0);  // default
  CHECK(hp.unit == "kW");
  CHECK(hp.range_min == -15.0);
  CHECK(hp.range_max == 15.0);
  CHECK(hp.role == PointRole::kInput);
  CHECK(hp.signal == "heat_pump_heat");

  CHECK(u.model.type == "zone_rc");
  const plant::ModelSchema* zone_rc = plant::find_schema("zone_rc");
  REQUIRE(zone_rc != nullptr);
  CHECK(u.model.parameters == plant::with_defaults(*zone_rc, {}));  // defaults written out

  CHECK(u.estimator.period_s == 60.0);
  CHECK(u.estimator.deadline_s == 0.5);
  CHECK(u.estimator.nis_gate == 10.83);                // default
  CHECK(u.estimator.robust_threshold == 2.0);          // default
  CHECK(u.estimator.max_consecutive_rejections == 5);  // default
  CHECK(u.estimator.measurement_noise ==
        std::map<std::string, double>{{"zone_air_temperature", 0.05}});
  CHECK(u.estimator.process_noise == std::map<std::string, double>{{"Q_int", 1.0}});
  CHECK(u.estimator.initial_state.empty());
  CHECK(u.estimator.initial_std.empty());

  CHECK(c.dds.domain_id == 0);
  CHECK(c.dds.interface == "lo");
  CHECK_FALSE(c.dds.allow_multicast);
  CHECK(c.dds.peers == std::vector<std::string>{"127.0.0.1"});
  CHECK(c.dds.topic_prefix == "hvac_twin");
  CHECK(c.runtime.time_scale == 60.0);
  CHECK(c.runtime.hang_timeout_s == 30.0);  // defaults
  CHECK(c.runtime.hang_exit);
  CHECK(c.runtime.overruns_before_watchdog_stop == 3);
  CHECK(c.runtime.log_level == "info");
  CHECK(c.runtime.recording_budget_mib == 64);  // the demo records, for hvac-twin-replay
}

TEST_CASE("omitted fields take the defaults of config.hpp", "[config]") {
  const LoadResult r = load(R"({
    "site_id": "s",
    "units": [{
      "id": "u",
      "model": {"type": "zone_rc"},
      "points": [
        {"name": "t", "address": 0, "unit": "degC", "range": [-20, 50],
         "signal": "zone_air_temperature"},
        {"name": "o", "address": 1, "unit": "degC", "range": [-40, 50], "role": "disturbance",
         "signal": "outdoor_temperature"},
        {"name": "q", "address": 2, "unit": "W", "range": [-9000, 9000], "role": "input",
         "signal": "heat_pump_heat"}
      ],
      "estimator": {"measurement_noise": {"zone_air_temperature": 0.1}}
    }]
  })");
  test::require_ok(r);
  const Config& c = *r.config;
  const Config defaults;
  CHECK(c.state_directory == defaults.state_directory);
  CHECK(c.dds.domain_id == defaults.dds.domain_id);
  CHECK(c.dds.interface == defaults.dds.interface);
  CHECK(c.dds.allow_multicast == defaults.dds.allow_multicast);
  CHECK(c.dds.peers == defaults.dds.peers);
  CHECK(c.dds.topic_prefix == defaults.dds.topic_prefix);
  CHECK(c.runtime.time_scale == defaults.runtime.time_scale);
  CHECK(c.runtime.hang_timeout_s == defaults.runtime.hang_timeout_s);
  CHECK(c.runtime.hang_exit == defaults.runtime.hang_exit);
  CHECK(c.runtime.overruns_before_watchdog_stop == defaults.runtime.overruns_before_watchdog_stop);
  CHECK(c.runtime.log_level == defaults.runtime.log_level);
  CHECK(c.runtime.recording_budget_mib == 0);  // no recording unless asked for

  const UnitConfig& u = c.units.at(0);
  const ModbusDeviceConfig m;
  CHECK(u.modbus.host == m.host);
  CHECK(u.modbus.port == m.port);
  CHECK(u.modbus.unit_id == m.unit_id);
  CHECK(u.modbus.response_timeout_s == m.response_timeout_s);
  CHECK(u.modbus.byte_timeout_s == m.byte_timeout_s);
  CHECK(u.modbus.poll_period_s == m.poll_period_s);
  CHECK(u.modbus.backoff_initial_s == m.backoff_initial_s);
  CHECK(u.modbus.backoff_max_s == m.backoff_max_s);
  CHECK(u.modbus.max_registers_per_request == m.max_registers_per_request);
  CHECK(u.model.parameters.empty());  // omitted parameters: the runtime takes the model's defaults

  const PointConfig p;
  const PointConfig& t = u.points.at(0);
  CHECK(t.kind == p.kind);
  CHECK(t.type == p.type);
  CHECK(t.word_order == p.word_order);
  CHECK(t.scale == p.scale);
  CHECK(t.offset == p.offset);
  CHECK(t.stale_after_s == p.stale_after_s);
  CHECK(t.role == p.role);

  const EstimatorConfig e;
  CHECK(u.estimator.period_s == e.period_s);
  CHECK(u.estimator.deadline_s == e.deadline_s);
  CHECK(u.estimator.nis_gate == e.nis_gate);
  CHECK(u.estimator.max_consecutive_rejections == e.max_consecutive_rejections);
}

TEST_CASE("the defaults of config.hpp satisfy the rules between fields", "[config]") {
  const ModbusDeviceConfig m;
  CHECK(m.response_timeout_s < m.poll_period_s / 2.0);
  CHECK(m.byte_timeout_s <= m.response_timeout_s);
  CHECK(m.backoff_initial_s <= m.backoff_max_s);
  CHECK(PointConfig{}.stale_after_s > m.poll_period_s);
  const EstimatorConfig e;
  const RuntimeConfig rt;
  CHECK(e.deadline_s <= e.period_s / rt.time_scale);
  CHECK(e.deadline_s < rt.hang_timeout_s);
}

TEST_CASE("config/README.md documents every model of the catalog, verbatim", "[config]") {
  const std::string readme = read_repo_file("config/README.md");
  std::string expected_all;
  for (const auto& schema : plant::model_schemas())
    expected_all += model_reference(schema) + "\n";
  bool all_found = true;
  for (const auto& schema : plant::model_schemas()) {
    const std::string expected = model_reference(schema);
    INFO("config/README.md must contain this section (regenerate it from the catalog):\n"
         << expected);
    CHECK(readme.find(expected) != std::string::npos);
    all_found = all_found && readme.find(expected) != std::string::npos;
  }
  if (!all_found) {  // leave the expected text where an editor can copy it from
    std::ofstream(std::string(HVAC_TWIN_BINARY_DIR) + "/config_model_reference.md") << expected_all;
  }
}

TEST_CASE("config/README.md lists every unit, and every catalog unit is in the table", "[config]") {
  const std::string readme = read_repo_file("config/README.md");
  for (const auto& u : known_units()) {
    INFO("unit " << u.name);
    CHECK(readme.find("| `" + std::string(u.name) + "` |") != std::string::npos);
  }
  for (const auto& schema : plant::model_schemas()) {
    const auto layout = schema.layout(plant::with_defaults(schema, {}));
    std::vector<std::string> units;
    for (const auto& p : schema.parameters)
      units.push_back(p.unit);
    for (const auto& s : layout.states)
      units.push_back(s.unit);
    for (const auto& s : layout.inputs)
      units.push_back(s.unit);
    for (const auto& s : layout.outputs)
      units.push_back(s.unit);
    for (const auto& unit : units) {
      INFO("model " << schema.type << " uses unit \"" << unit << "\"");
      CHECK(find_unit(unit) != nullptr);
    }
  }
}

TEST_CASE("the annotated example of config/README.md is valid once its comments go", "[config]") {
  const std::string readme = read_repo_file("config/README.md");
  const auto begin = readme.find("```jsonc\n");
  REQUIRE(begin != std::string::npos);
  const auto end = readme.find("```\n", begin + 9);
  REQUIRE(end != std::string::npos);
  std::string json;
  std::istringstream lines(readme.substr(begin + 9, end - begin - 9));
  for (std::string line; std::getline(lines, line);)  // no "//" inside its strings
    json += line.substr(0, line.find("//")) + "\n";
  const LoadResult r = load(json);
  test::require_ok(r);
  // It sets what the demo sets.
  const LoadResult demo = load(read_repo_file("config/demo.json"));
  test::require_ok(demo);
  CHECK(r.config->units[0].points.size() == demo.config->units[0].points.size());
  CHECK(r.config->units[0].model.parameters == demo.config->units[0].model.parameters);
}

TEST_CASE("the invalid example reports each of its errors, in document order", "[config]") {
  const LoadResult r = load(read_repo_file("config/examples/several-errors.json"));
  INFO(test::describe(r));
  CHECK_FALSE(r.config.has_value());
  std::vector<std::string> pointers;
  for (const auto& e : r.errors)
    pointers.push_back(e.pointer);
  CHECK(pointers == std::vector<std::string>{
                        "/site_id",
                        "/units/0/modbus/port",
                        "/units/0/modbus/response_timeout_s",
                        "/units/0/modbus/byte_timout_s",
                        "/units/0/points/0/word_order",
                        "/units/0/points/1",
                        "/units/0/points/2/type",
                        "/units/0/points/2/unit",
                        "/units/0/points/2/range",
                        "/units/0/model/parameters/C_ari",
                        "/units/0/model/parameters/UA_air_out",
                        "/units/0/estimator/deadline_s",
                        "/units/0/estimator/measurement_noise",
                        "/runtime/log_level",
                    });
}

TEST_CASE("the syntax-error example reports its line and column", "[config]") {
  test::require_single_error(load(read_repo_file("config/examples/syntax-error.json")), "",
                             {"invalid JSON at line 10, column 17", "expected '}'"});
}

TEST_CASE("format_errors prints one line per error, (root) for the empty pointer", "[config]") {
  const std::vector<ConfigError> errors{{"", "the document is empty; expected a JSON object"},
                                        {"/units/0/modbus/port", "expected an integer"},
                                        {"/a\nb", "line\tbreak"}};
  CHECK(format_errors(errors, "site.json") ==
        "site.json: (root): the document is empty; expected a JSON object\n"
        "site.json: /units/0/modbus/port: expected an integer\n"
        "site.json: /a\\u000ab: line\\u0009break\n");
  CHECK(format_errors({}, "site.json").empty());
}

TEST_CASE("load_config_file reads files and reports unreadable ones at the root", "[config]") {
  const auto& models = plant::model_schemas();
  const LoadResult demo =
      load_config_file(std::string(HVAC_TWIN_SOURCE_DIR) + "/config/demo.json", models);
  test::require_ok(demo);

  const LoadResult missing = load_config_file("/nonexistent/hvac-twin.json", models);
  test::require_single_error(missing, "", {"cannot read the file"});

  const LoadResult directory = load_config_file(std::string(HVAC_TWIN_SOURCE_DIR), models);
  test::require_single_error(directory, "", {"cannot read the file", "not a regular file"});

  const LoadResult invalid = load_config_file(
      std::string(HVAC_TWIN_SOURCE_DIR) + "/config/examples/several-errors.json", models);
  CHECK(invalid.errors.size() > 5);
}

}  // namespace
}  // namespace hvac_twin::config
