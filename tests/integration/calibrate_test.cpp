// hvac-twin-calibrate end to end: the simulator's commissioning run of a truth whose factors
// differ from the nominal (the configured model's own closures, so the factors have true values)
// written as a points CSV, the fit recovering them within its sigma, the configuration including
// the file it writes, and bad input refused with a message that names it.
#include <catch2/catch.hpp>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "config/load.hpp"
#include "plant_models/catalog.hpp"
#include "tests/integration/process.hpp"
#include "tests/support/scratch_dir.hpp"

using namespace hvac_twin::test;
using namespace std::chrono_literals;

namespace {

const std::string kConfig = std::string(HVAC_TWIN_SOURCE_DIR) + "/config/demo-heat-pump.json";

struct Run {
  int rc = -1;
  std::string err;
};

Run run(const ScratchDir& dir, const char* exe, const std::vector<std::string>& args) {
  const std::string out = dir / "run.out", err = dir / "run.err";
  Process p(exe, args, out, err);
  Run r{p.wait(600s).value_or(-1), ""};
  std::ifstream in(err);
  r.err.assign(std::istreambuf_iterator<char>(in), {});
  return r;
}

// The truth's factors (simulator --set) and the fitted names.
const std::vector<std::pair<std::string, double>> kTruth{{"fouling", 0.85},
                                                         {"evap_ua_factor", 1.12},
                                                         {"comp_flow_factor", 0.95},
                                                         {"valve_factor", 0.9},
                                                         {"comp_efficiency_factor", 1.06}};

}  // namespace

TEST_CASE("hvac-twin-calibrate recovers a commissioning run's factors and the unit includes them",
          "[calibration][integration]") {
  ScratchDir dir("calibrate");
  const std::string csv = dir / "commissioning.csv", cal = dir / "hp1.calibration.json";
  std::vector<std::string> sim{"--config", kConfig, "--commissioning", "--as-configured",
                               "--step",   "5",     "--quiet"};
  std::string fit;
  for (const auto& [name, value] : kTruth) {
    sim.insert(sim.end(), {"--set", name + "=" + std::to_string(value)});
    fit += (fit.empty() ? "" : ",") + name;
  }
  // The outdoor coil's outlet thermistor reads 0.5 K low.
  sim.insert(sim.end(), {"--bias", "outdoor_coil_out_temp=-0.5", "--write-points", csv, "4.5"});
  const Run simulated = run(dir, HVAC_TWIN_SIM_EXE, sim);
  INFO(simulated.err);
  REQUIRE(simulated.rc == 0);

  const std::string report = dir / "calibration.html";
  const Run fitted = run(dir, HVAC_TWIN_CALIBRATE_EXE,
                         {"--config", kConfig, "--charge", "0.5", "--fit", fit, "--offsets",
                          "outdoor_coil_out_temp=1", "--out", cal, "--report", report, csv});
  INFO(fitted.err);
  REQUIRE(fitted.rc == 0);
  CHECK_THAT(fitted.err, Catch::Contains("on 6 windows"));
  std::ifstream in(cal);
  const auto file = nlohmann::json::parse(in);
  for (const auto& [name, truth] : kTruth) {
    const auto& p = file["fit"]["parameters"][name];
    const double value = p["value"], sigma = p["sigma"], prior_sigma = p["prior_sigma"];
    INFO(name << ": truth " << truth << ", fit " << value << " +- " << sigma);
    CHECK(std::abs(value - truth) < 3.0 * sigma);
    CHECK(sigma < prior_sigma / 2.0);
    CHECK(file["parameters"][name] == value);
  }
  // The report: the parameter table and one residual chart per measured point.
  std::ifstream html_in(report);
  const std::string html{std::istreambuf_iterator<char>(html_in), {}};
  for (const auto& [name, truth] : kTruth)
    CHECK_THAT(html, Catch::Contains("<th>" + name + "</th>"));
  std::size_t charts = 0;
  for (auto at = html.find("<svg"); at != std::string::npos; at = html.find("<svg", at + 1))
    ++charts;
  CHECK(charts >= 6);
  CHECK_THAT(html, Catch::Contains("discharge_pressure") && Catch::Contains("measured − model"));
  // The thermistor's offset, found and corrected by the point's configured offset.
  const auto& offset = file["fit"]["parameters"]["offset of outdoor_coil_out_temp [degC]"];
  INFO("offset " << offset.dump());
  CHECK(std::abs(offset["value"].get<double>() + 0.5) < 3.0 * offset["sigma"].get<double>());
  CHECK(offset["sigma"].get<double>() < 0.5);
  CHECK(file["point_offsets"]["outdoor_coil_out_temp"] == -offset["value"].get<double>());
  // The unit's filter carries fouling as a state (its sigma goes along); the valve factor is a
  // constant of its model (its value only).
  CHECK(file["initial_std"].contains("fouling"));
  CHECK_FALSE(file["initial_std"].contains("valve_factor"));

  auto site = nlohmann::json::parse(std::ifstream(kConfig));
  site["units"][0]["calibration"] = "hp1.calibration.json";
  std::ofstream(dir / "site.json") << site.dump();
  const auto loaded =
      hvac_twin::config::load_config_file(dir / "site.json", hvac_twin::plant::model_schemas());
  REQUIRE(loaded.errors.empty());
  CHECK(loaded.config->units[0].model.parameters.at("valve_factor") ==
        file["parameters"]["valve_factor"].get<double>());
}

TEST_CASE("hvac-twin-calibrate refuses bad input, naming what was wrong",
          "[calibration][integration]") {
  ScratchDir dir("calibrate-bad");
  const std::string csv = dir / "short.csv";
  const Run simulated = run(dir, HVAC_TWIN_SIM_EXE,
                            {"--config", kConfig, "--commissioning", "--step", "5", "--quiet",
                             "--write-points", csv, "0.25"});
  REQUIRE(simulated.rc == 0);
  auto calibrate = [&](std::vector<std::string> args) {
    args.insert(args.begin(), {"--config", kConfig});
    return run(dir, HVAC_TWIN_CALIBRATE_EXE, args);
  };
  SECTION("no steady window") {
    const Run r = calibrate({"--charge", "0.5", csv});
    CHECK(r.rc == 65);
    CHECK_THAT(r.err, Catch::Contains("no steady window") && Catch::Contains("--settle-s"));
  }
  SECTION("the charge missing or out of range") {
    CHECK_THAT(calibrate({csv}).err, Catch::Contains("--charge KG is required"));
    const Run r = calibrate({"--charge", "50", csv});
    CHECK(r.rc == 2);
    CHECK_THAT(r.err, Catch::Contains("--charge: expected kg in"));
  }
  SECTION("a parameter the model cannot fit") {
    const Run r = calibrate({"--charge", "0.5", "--fit", "fouling,cells", csv});
    CHECK(r.rc == 2);
    CHECK_THAT(r.err, Catch::Contains("cells is not a parameter"));
    const Run twice = calibrate({"--charge", "0.5", "--fit", "fouling,fouling", csv});
    CHECK(twice.rc == 2);
    CHECK_THAT(twice.err, Catch::Contains("fouling is named twice"));
  }
  SECTION("a bad CSV line") {
    std::ofstream(dir / "bad.csv") << "time,compressor_speed\n1782892800,50\n1782892802,fast\n";
    const Run r = calibrate({"--charge", "0.5", dir / "bad.csv"});
    CHECK(r.rc == 65);
    CHECK_THAT(r.err, Catch::Contains("bad.csv") && Catch::Contains("line 3"));
  }
}
