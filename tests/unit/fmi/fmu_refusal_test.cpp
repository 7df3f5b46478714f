// What the FMU import refuses, and how it says so: each error names the file and what is wrong.
// The FMUs here are the exported zone model's, repacked with one thing changed.
#include <catch2/catch.hpp>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "io/fmi/import/fmu_archive.hpp"
#include "io/fmi/import/fmu_model.hpp"
#include "plant_models/catalog.hpp"
#include "tests/support/edited_fmu.hpp"
#include "tests/support/scratch_dir.hpp"

using namespace hvac_twin;

namespace {

using test::write_zip;
std::string description() {
  return test::zone_fmu_description();
}
std::string binary() {
  return test::zone_fmu_binary();
}

// The zone FMU with `from` replaced by `to` in its description (which must contain it).
std::string edited(const test::ScratchDir& dir, const std::string& from, const std::string& to) {
  const std::string path = dir / "edited.fmu";
  test::write_edited_zone_fmu(path, from, to);
  return path;
}

void load(const test::ScratchDir& dir, const std::string& fmu) {
  const auto lib = fmi::load_fmu(fmu, dir / "unpacked");
  const fmi::FmuModel model(lib, {});
}

}  // namespace

TEST_CASE("the repacked zone FMU loads: the refusals below are each for their one change",
          "[fmi]") {
  const test::ScratchDir dir("fmu-control");
  const std::string path = dir / "control.fmu";
  write_zip(path,
            {{"modelDescription.xml", description()}, {"binaries/linux64/zone_rc.so", binary()}});
  CHECK_NOTHROW(load(dir, path));
  CHECK_NOTHROW(load(dir, edited(dir, "zone_rc", "zone_rc")));
}

TEST_CASE("an FMU that is missing or not an archive is refused by name", "[fmi]") {
  const test::ScratchDir dir("fmu-missing");
  CHECK_THROWS_WITH(load(dir, dir / "nowhere.fmu"), Catch::Contains("nowhere.fmu: no such file"));
  std::ofstream(dir / "text.fmu") << "this is not a zip archive";
  CHECK_THROWS_WITH(load(dir, dir / "text.fmu"),
                    Catch::Contains("text.fmu: cannot open as an FMU (zip archive)"));
  write_zip(dir / "empty.fmu", {{"binaries/linux64/zone_rc.so", binary()}});
  CHECK_THROWS_WITH(load(dir, dir / "empty.fmu"),
                    Catch::Contains("modelDescription.xml: missing from the FMU"));
  write_zip(dir / "nobinary.fmu", {{"modelDescription.xml", description()}});
  CHECK_THROWS_WITH(load(dir, dir / "nobinary.fmu"),
                    Catch::Contains("no linux64 binary (binaries/linux64/zone_rc.so)"));
}

TEST_CASE("an FMU entry that would unpack outside its directory is refused", "[fmi]") {
  const test::ScratchDir dir("fmu-slip");
  for (const std::string name : {"../escaped.txt", "binaries/../../escaped.txt", "/abs.txt"}) {
    INFO(name);
    write_zip(dir / "slip.fmu", {{"modelDescription.xml", description()}, {name, "x"}});
    CHECK_THROWS_WITH(fmi::unpack_fmu(dir / "slip.fmu", dir / "unpacked"),
                      Catch::Contains("\"" + name + "\" would unpack outside its directory"));
    CHECK_FALSE(std::filesystem::exists(dir / "escaped.txt"));
  }
}

TEST_CASE("what the import does not support is refused with the reason", "[fmi]") {
  const test::ScratchDir dir("fmu-unsupported");
  CHECK_THROWS_WITH(load(dir, edited(dir, "fmiVersion=\"2.0\"", "fmiVersion=\"1.0\"")),
                    Catch::Contains("fmiVersion is \"1.0\"; only FMI 2.0 is supported"));
  CHECK_THROWS_WITH(load(dir, edited(dir, "fmiVersion=\"2.0\"", "fmiVersion=\"3.0\"")),
                    Catch::Contains("fmiVersion is \"3.0\"; only FMI 2.0 is supported"));
  CHECK_THROWS_WITH(load(dir, edited(dir, "<ModelExchange", "<CoSimulation")),
                    Catch::Contains("not a Model Exchange FMU"));
  CHECK_THROWS_WITH(
      load(dir, edited(dir, "numberOfEventIndicators=\"0\"", "numberOfEventIndicators=\"2\"")),
      Catch::Contains("2 event indicators; FMUs with state events are not supported"));
  CHECK_THROWS_WITH(load(dir, edited(dir,
                                     "causality=\"local\" variability=\"continuous\" "
                                     "initial=\"exact\" description=\"building-mass",
                                     "causality=\"local\" variability=\"discrete\" "
                                     "initial=\"exact\" description=\"building-mass")),
                    Catch::Contains("\"T_mass\" is discrete"));
  CHECK_THROWS_WITH(load(dir, edited(dir, "<fmiModelDescription", "<fmiModelDescriptio")),
                    Catch::Contains("not well-formed XML"));
  CHECK_THROWS_WITH(
      load(dir, edited(dir, "modelIdentifier=\"zone_rc\"", "modelIdentifier=\"../zone_rc\"")),
      Catch::Contains("modelIdentifier \"../zone_rc\" is not a file name"));
}

TEST_CASE("an FMU whose binary refuses the description's GUID is refused at instantiation",
          "[fmi]") {
  const test::ScratchDir dir("fmu-guid");
  const std::string xml = description();
  const auto at = xml.find("guid=\"{") + 7;
  CHECK_THROWS_WITH(load(dir, edited(dir, xml.substr(at, 8), "00000000")),
                    Catch::Contains("fmi2Instantiate refused") && Catch::Contains("GUID"));
}

TEST_CASE("an FMU that returns fmi2Error fails the model for good and says why", "[fmi]") {
  const test::ScratchDir dir("fmu-error");
  // The description maps the first output to a value reference the binary does not have: the
  // binary answers fmi2GetReal with fmi2Error.
  const std::string path =
      edited(dir, test::zone_fmu_first_output_ref(), "valueReference=\"9999\"");
  // <Outputs> names the variable by index, not by reference: the edit keeps the structure valid.
  const auto lib = fmi::load_fmu(path, dir / "unpacked");
  const fmi::FmuModel model(lib, {});
  const std::vector<double> x{20.0, 20.0, 300.0}, u{0.0, 10.0};
  std::vector<double> xdot(3), y(model.num_outputs());
  CHECK(model.rhs(x, u, xdot) == plant::kModelOk);
  CHECK(model.failure() == nullptr);
  CHECK(model.outputs(x, u, y) == plant::kModelFatal);
  REQUIRE(model.failure() != nullptr);
  CHECK_THAT(std::string(model.failure()), Catch::Contains("no variable has value reference 9999"));
  CHECK(model.rhs(x, u, xdot) == plant::kModelFatal);  // not called again
}

TEST_CASE("a state without a start value starts where the FMU's initialisation puts it", "[fmi]") {
  // The zone FMU with T_air's start attribute removed from its description: the layout the
  // description gives starts it at 0, the FMU's own initialisation at 20 degC.
  const test::ScratchDir dir("fmu-start");
  const std::string xml = description();
  const auto t_air = xml.find("name=\"T_air\"");
  const auto start = xml.find(" start=\"20\"", t_air);
  REQUIRE(start != std::string::npos);
  const std::string line = xml.substr(t_air, start + 11 - t_air);
  const std::string path =
      edited(dir, line, line.substr(0, line.size() - std::string(" start=\"20\"").size()));
  const auto lib = fmi::load_fmu(path, dir / "unpacked");
  CHECK(fmi::fmu_layout(fmi::description_of(*lib), {}).states[0].initial == 0.0);
  const fmi::FmuModel model(lib, {});
  CHECK(model.layout().states[0].initial == 20.0);
}

TEST_CASE("an FMU without directional derivatives is differentiated by central differences",
          "[fmi]") {
  // The zone FMU declaring providesDirectionalDerivative="false": the import takes the
  // finite-difference path by itself, and its Jacobians match the built-in model's AD ones.
  const test::ScratchDir dir("fmu-nodd");
  const std::string path = edited(dir, "providesDirectionalDerivative=\"true\"",
                                  "providesDirectionalDerivative=\"false\"");
  const auto lib = fmi::load_fmu(path, dir / "unpacked");
  const fmi::FmuModel model(lib, {});
  CHECK(model.jacobian_method() == fmi::JacobianMethod::kFiniteDifferences);
  const auto ref = plant::create_model("zone_rc", {});
  const std::vector<double> x{24.0, 22.0, 500.0}, u{-3000.0, 31.0};
  std::vector<double> J(9), J_ref(9), H(12), H_ref(12);
  REQUIRE(model.rhs_jacobian(x, u, {}, J) == plant::kModelOk);
  REQUIRE(ref->rhs_jacobian(x, u, {}, J_ref) == plant::kModelOk);
  REQUIRE(model.output_jacobian(x, u, {}, H) == plant::kModelOk);
  REQUIRE(ref->output_jacobian(x, u, {}, H_ref) == plant::kModelOk);
  for (std::size_t i = 0; i < J.size(); ++i)
    CHECK(J[i] == Approx(J_ref[i]).epsilon(1e-6).margin(1e-12));
  for (std::size_t i = 0; i < H.size(); ++i)
    CHECK(H[i] == Approx(H_ref[i]).epsilon(1e-6).margin(1e-9));
}
