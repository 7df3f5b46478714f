// What the FMU import refuses, and how it says so: each error names the file and what is wrong.
// The FMUs here are the exported zone model's, repacked with one thing changed.
#include <zip.h>

#include <catch2/catch.hpp>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "io/fmi/import/fmu_archive.hpp"
#include "io/fmi/import/fmu_model.hpp"
#include "tests/support/scratch_dir.hpp"

using namespace hvac_twin;

namespace {

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  REQUIRE(in);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

const std::string kStage = std::string(HVAC_TWIN_BINARY_DIR) + "/fmu/zone_rc/";

std::string description() {
  return read_file(kStage + "modelDescription.xml");
}
std::string binary() {
  return read_file(kStage + "binaries/linux64/zone_rc.so");
}

// Writes a zip archive of (name, content) entries.
void write_zip(const std::string& path, const std::vector<std::pair<std::string, std::string>>& e) {
  int error = 0;
  zip_t* z = zip_open(path.c_str(), ZIP_CREATE | ZIP_TRUNCATE, &error);
  REQUIRE(z != nullptr);
  for (const auto& [name, content] : e) {
    zip_source_t* src = zip_source_buffer(z, content.data(), content.size(), 0);
    REQUIRE(src != nullptr);
    REQUIRE(zip_file_add(z, name.c_str(), src, ZIP_FL_ENC_UTF_8) >= 0);
  }
  REQUIRE(zip_close(z) == 0);
}

// The zone FMU with `from` replaced by `to` in its description (which must contain it).
std::string edited(const test::ScratchDir& dir, const std::string& from, const std::string& to) {
  std::string xml = description();
  const auto at = xml.find(from);
  REQUIRE(at != std::string::npos);
  xml.replace(at, from.size(), to);
  const std::string path = dir / "edited.fmu";
  write_zip(path, {{"modelDescription.xml", xml}, {"binaries/linux64/zone_rc.so", binary()}});
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
  const std::string xml = description();
  const auto output = xml.find("causality=\"output\"");
  const auto ref_at = xml.rfind("valueReference=\"", output);
  const auto ref_end = xml.find('"', ref_at + 16);
  const std::string old_ref = xml.substr(ref_at, ref_end + 1 - ref_at);
  const std::string path = edited(dir, old_ref, "valueReference=\"9999\"");
  // <Outputs> names the variable by index, not by reference: the edit keeps the structure valid.
  const auto lib = fmi::load_fmu(path, dir / "unpacked");
  const fmi::FmuModel model(lib, {});
  const std::vector<double> x{20.0, 20.0, 300.0}, u{0.0, 10.0};
  std::vector<double> xdot(3), y(model.num_outputs());
  CHECK(model.rhs(x, u, xdot) == plant::kModelOk);
  CHECK(model.outputs(x, u, y) == plant::kModelFatal);
  CHECK(model.failed());
  CHECK_THAT(model.last_error(), Catch::Contains("no variable has value reference 9999"));
  CHECK(model.rhs(x, u, xdot) == plant::kModelFatal);  // not called again
}
