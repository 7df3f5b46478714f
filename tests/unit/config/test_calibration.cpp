// A unit's "calibration" file (config/calibration_file.hpp): its values land in the unit's model
// parameters and filter sigmas, validated as if written there, and every error names the file,
// the key in it, and the unit's "calibration" key.
#include <catch2/catch.hpp>
#include <fstream>

#include "config/calibration_file.hpp"
#include "plant_models/catalog.hpp"
#include "tests/support/scratch_dir.hpp"
#include "tests/unit/config/config_test_support.hpp"

namespace hvac_twin::config {
namespace {

void write(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
}

CalibrationFile calibration() {
  CalibrationFile f;
  f.unit = "hp1";
  f.model = "heat_pump_r32";
  f.parameters = {{"fouling", 0.8}, {"valve_factor", 0.9}};
  f.initial_std = {{"fouling", 0.03}};
  f.point_offsets = {{"outdoor_coil_in_temp", 0.3}};
  return f;
}

struct Site {
  hvac_twin::test::ScratchDir dir{"config-calibration"};
  nlohmann::json doc = nlohmann::json::parse(test::read_repo_file("config/demo-heat-pump.json"));

  Site() { doc["units"][0]["calibration"] = "hp1.calibration.json"; }
  LoadResult load(const CalibrationFile& f = calibration()) {
    write(dir / "hp1.calibration.json", write_calibration(f));
    write(dir / "site.json", doc.dump());
    return load_config_file(dir / "site.json", plant::model_schemas());
  }
};

TEST_CASE("a unit's calibration file sets its model parameters and filter sigmas",
          "[config][calibration]") {
  Site site;
  const LoadResult r = site.load();
  test::require_ok(r);
  const auto& unit = r.config->units[0];
  CHECK(unit.calibration == "hp1.calibration.json");
  CHECK(unit.model.parameters.at("fouling") == 0.8);
  CHECK(unit.model.parameters.at("valve_factor") == 0.9);
  CHECK(unit.estimator.initial_std.at("fouling") == 0.03);
  // A point offset corrects the reading: added to the configured offset.
  const auto offset_of = [](const UnitConfig& u, const std::string& name) {
    for (const auto& p : u.points)
      if (p.name == name) return p.offset;
    return -1e9;
  };
  CHECK(offset_of(unit, "outdoor_coil_in_temp") == 0.3);
  CHECK(offset_of(unit, "outdoor_coil_out_temp") == 0.0);
  // The configuration's own values are kept.
  CHECK(unit.model.parameters.at("augment_fouling") == 1.0);
  CHECK(unit.estimator.measurement_noise.at("suction_pressure") == 5000.0);

  SECTION("a point offset adds to the configured one") {
    for (auto& p : site.doc["units"][0]["points"])
      if (p["name"] == "outdoor_coil_in_temp") p["offset"] = -1.0;
    const LoadResult again = site.load();
    test::require_ok(again);
    CHECK(offset_of(again.config->units[0], "outdoor_coil_in_temp") == Approx(-0.7));
  }
  SECTION("an absolute path") {
    site.doc["units"][0]["calibration"] = site.dir / "hp1.calibration.json";
    test::require_ok(site.load());
  }
}

TEST_CASE("a bad calibration file is an error naming the file, the key in it and the unit's key",
          "[config][calibration]") {
  Site site;
  const std::string at = "/units/0/calibration";
  auto f = calibration();
  SECTION("missing") {
    site.doc["units"][0]["calibration"] = "nowhere.json";
    test::require_single_error(site.load(), at, {"nowhere.json", "cannot read the file"});
  }
  SECTION("a value outside the parameter's range") {
    f.parameters["fouling"] = 5.0;
    test::require_single_error(site.load(f), at,
                               {"hp1.calibration.json: /parameters/fouling", "5"});
  }
  SECTION("a sigma of a state the unit's filter does not carry") {
    f.initial_std["valve_factor"] = 0.02;
    test::require_single_error(site.load(f), at,
                               {"/initial_std/valve_factor", "unknown state \"valve_factor\""});
  }
  SECTION("a parameter the model does not have") {
    f.parameters["foulling"] = 0.9;
    test::require_single_error(site.load(f), at, {"/parameters/foulling", "did you mean"});
  }
  SECTION("an offset of a point the unit does not have") {
    f.point_offsets["outdoor_coil_temp"] = 0.1;
    test::require_single_error(site.load(f), at,
                               {"/point_offsets/outdoor_coil_temp", "has no point"});
  }
  SECTION("a value the configuration sets too") {
    site.doc["units"][0]["model"]["parameters"]["fouling"] = 1.0;
    test::require_single_error(
        site.load(f), at,
        {"/parameters/fouling", "the configuration sets it too", "/units/0/model/parameters"});
  }
  SECTION("another unit's calibration") {
    f.unit = "hp2";
    test::require_single_error(site.load(f), at, {"a calibration of unit hp2", "not of unit hp1"});
  }
  SECTION("not a calibration file") {
    write(site.dir / "hp1.calibration.json", R"({"format": "hvac-twin calibration"})");
    write(site.dir / "site.json", site.doc.dump());
    test::require_single_error(load_config_file(site.dir / "site.json", plant::model_schemas()), at,
                               {"hp1.calibration.json", "/version: expected 1"});
    write(site.dir / "hp1.calibration.json", "{");
    test::require_single_error(load_config_file(site.dir / "site.json", plant::model_schemas()), at,
                               {"hp1.calibration.json", "not JSON"});
    auto text = nlohmann::json::parse(write_calibration(f));
    text["parameters"]["fouling"] = "0.8";
    write(site.dir / "hp1.calibration.json", text.dump());
    test::require_single_error(load_config_file(site.dir / "site.json", plant::model_schemas()), at,
                               {"/parameters/fouling: expected a finite number"});
    text = nlohmann::json::parse(write_calibration(f));
    text["paramters"] = nlohmann::json::object();
    write(site.dir / "hp1.calibration.json", text.dump());
    test::require_single_error(load_config_file(site.dir / "site.json", plant::model_schemas()), at,
                               {"/paramters: unknown key"});
  }
}

}  // namespace
}  // namespace hvac_twin::config
