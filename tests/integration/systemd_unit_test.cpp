// The service as installed, checked without a running systemd: `cmake --install` lays out the
// daemon, the echo tool, the unit, the DDS Security drop-in and templates, the example
// configuration and the IDL; the installed unit has what issue 7 asks for, passes
// `systemd-analyze verify` without a word (also with the drop-in) and rates at most 1.5 in
// `systemd-analyze security --offline=true`; the example configuration is valid and its cycle
// fits the unit's WatchdogSec. Each check is shown to fail on a bad unit. The dashboard's unit
// (hvac-twin-web.service) is installed, verified and rated the same way.
#include <sys/stat.h>

#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>

#include "tests/integration/systemd_support.hpp"
#include "tests/support/scratch_dir.hpp"

using namespace hvac_twin::test;
using namespace std::chrono_literals;

namespace {

namespace fs = std::filesystem;

// A fresh install tree for one test case.
struct InstallTree {
  hvac_twin::test::ScratchDir scratch;
  const fs::path& prefix;
  RunResult result;

  explicit InstallTree(const std::string& name)
      : scratch("install-" + name),
        prefix(scratch.path()),
        result(run({CMAKE_COMMAND_PATH, "--install", HVAC_TWIN_BINARY_DIR, "--prefix",
                    prefix.string()})) {}
  fs::path unit_dir() const {
    const fs::path dir = HVAC_TWIN_SYSTEMD_UNIT_DIR;
    return dir.is_absolute() ? dir : prefix / dir;
  }
  fs::path unit() const { return unit_dir() / "hvac-twind.service"; }
  fs::path web_unit() const { return unit_dir() / "hvac-twin-web.service"; }
  fs::path operator/(const std::string& relative) const { return prefix / relative; }
};

bool executable(const fs::path& p) {
  struct stat st {};
  return ::stat(p.c_str(), &st) == 0 && S_ISREG(st.st_mode) && (st.st_mode & S_IXUSR) != 0;
}

// The number of "Overall exposure level for UNIT: 1.0 OK", or -1 if there is none.
double exposure(const RunResult& r) {
  const std::string marker = "Overall exposure level for ";
  const auto at = r.output.find(marker);
  if (at == std::string::npos) return -1.0;
  const auto colon = r.output.find(": ", at + marker.size());
  if (colon == std::string::npos) return -1.0;
  const char* start = r.output.c_str() + colon + 2;
  char* end = nullptr;
  const double value = std::strtod(start, &end);
  return end == start ? -1.0 : value;
}

}  // namespace

TEST_CASE("cmake --install lays out the service", "[integration][systemd][install]") {
  const InstallTree tree("layout");
  INFO(tree.result.output);
  REQUIRE(tree.result.status == 0);
  CHECK(executable(tree / "sbin/hvac-twind"));
  CHECK(executable(tree / "bin/hvac-twin-echo"));
  CHECK(executable(tree / "bin/hvac-twin-web"));
  CHECK(fs::is_regular_file(tree.unit()));
  CHECK(fs::is_regular_file(tree.web_unit()));
  for (const char* file :
       {"share/doc/hvac_twin/README.md", "share/doc/hvac_twin/examples/hvac-twin.example.json",
        "share/doc/hvac_twin/examples/dds-security.conf",
        "share/doc/hvac_twin/examples/web-credentials.conf", "share/hvac-twin/idl/hvac_twin.idl",
        "share/hvac-twin/security/governance.xml",
        "share/hvac-twin/security/permissions-publisher.xml",
        "share/hvac-twin/security/permissions-subscriber.xml"}) {
    INFO(file);
    CHECK(fs::is_regular_file(tree / file));
  }

  // The installed unit is the shipped one, with the binary and documentation of this prefix.
  std::string expected =
      read_file(std::string(HVAC_TWIN_SOURCE_DIR) + "/systemd/hvac-twind.service");
  replace_all(expected, "ExecStart=/usr/sbin/hvac-twind ",
              "ExecStart=" + (tree / "sbin/hvac-twind").string() + " ");
  replace_all(expected, "file:///usr/share/doc/hvac_twin/",
              "file://" + (tree / "share/doc/hvac_twin/").string());
  CHECK(read_file(tree.unit().string()) == expected);
  std::string expected_web =
      read_file(std::string(HVAC_TWIN_SOURCE_DIR) + "/systemd/hvac-twin-web.service");
  replace_all(expected_web, "ExecStart=/usr/bin/hvac-twin-web ",
              "ExecStart=" + (tree / "bin/hvac-twin-web").string() + " ");
  replace_all(expected_web, "file:///usr/share/doc/hvac_twin/",
              "file://" + (tree / "share/doc/hvac_twin/").string());
  CHECK(read_file(tree.web_unit().string()) == expected_web);

  // The installed daemon accepts the installed example configuration.
  const RunResult check =
      run({(tree / "sbin/hvac-twind").string(), "--check-config",
           (tree / "share/doc/hvac_twin/examples/hvac-twin.example.json").string()});
  INFO(check.output);
  CHECK(check.status == 0);
  CHECK_THAT(check.output, Catch::Contains("valid"));
}

TEST_CASE("the installed unit passes systemd-analyze verify without a word",
          "[integration][systemd][install]") {
  const InstallTree tree("verify");
  REQUIRE(tree.result.status == 0);
  const RunResult plain = run({"systemd-analyze", "verify", tree.unit().string()});
  INFO("verify:\n" << plain.output);
  CHECK(plain.status == 0);
  CHECK(plain.output.empty());

  // With the DDS Security drop-in in place, as README's installation steps put it.
  const fs::path dropin_dir = tree.unit_dir() / "hvac-twind.service.d";
  fs::create_directories(dropin_dir);
  fs::copy_file(tree / "share/doc/hvac_twin/examples/dds-security.conf",
                dropin_dir / "dds-security.conf");
  const RunResult with_dropin = run({"systemd-analyze", "verify", tree.unit().string()});
  INFO("verify with drop-in:\n" << with_dropin.output);
  CHECK(with_dropin.status == 0);
  CHECK(with_dropin.output.empty());

  // The check bites: a key systemd 252 does not know is reported.
  fs::remove_all(dropin_dir);
  std::string bad = read_file(tree.unit().string());
  replace_all(bad, "Restart=on-failure\n", "Restart=on-failure\nRestartSteps=3\n");
  const fs::path bad_unit = tree.unit_dir() / "hvac-twind-bad.service";
  std::ofstream(bad_unit) << bad;
  const RunResult broken = run({"systemd-analyze", "verify", bad_unit.string()});
  CHECK_THAT(broken.output, Catch::Contains("RestartSteps"));
}

TEST_CASE("the installed unit rates at most 1.5 in systemd-analyze security",
          "[integration][systemd][install]") {
  const InstallTree tree("security");
  REQUIRE(tree.result.status == 0);
  const RunResult r =
      run({"systemd-analyze", "security", "--offline=true", "--no-pager", tree.unit().string()});
  INFO(r.output);
  REQUIRE(r.status == 0);
  const double score = exposure(r);
  REQUIRE(score >= 0.0);
  CHECK(score <= 1.5);  // issue 7; it rates 1.0 on systemd 252, a networked service's minimum

  // The score is read correctly: an unhardened unit rates far worse.
  const fs::path bare = tree.unit_dir() / "bare.service";
  std::ofstream(bare) << "[Service]\nExecStart=" << (tree / "sbin/hvac-twind").string() << "\n";
  CHECK(exposure(run(
            {"systemd-analyze", "security", "--offline=true", "--no-pager", bare.string()})) > 5.0);
}

TEST_CASE("the unit has what the service needs, in the right sections", "[integration][systemd]") {
  const auto unit = parse_unit(std::string(HVAC_TWIN_SOURCE_DIR) + "/systemd/hvac-twind.service");
  const auto value = [&](const std::string& section, const std::string& key) {
    const auto it = unit.find(section + "." + key);
    return it == unit.end() || it->second.empty() ? std::string("<missing>") : it->second.back();
  };
  CHECK(value("Service", "Type") == "notify");
  CHECK(value("Service", "NotifyAccess") == "main");
  CHECK(value("Service", "Restart") == "on-failure");
  CHECK(value("Service", "RestartPreventExitStatus") == "78");
  CHECK(value("Service", "DynamicUser") == "yes");
  CHECK(value("Service", "StateDirectory") == "hvac-twin");
  CHECK(value("Service", "ConfigurationDirectory") == "hvac-twin");
  CHECK(value("Service", "RestrictAddressFamilies") == "AF_UNIX AF_INET AF_INET6 AF_NETLINK");
  // Start limits belong in [Unit]; in [Service] only deprecated spellings exist.
  CHECK(value("Unit", "StartLimitIntervalSec") != "<missing>");
  CHECK(value("Unit", "StartLimitBurst") != "<missing>");
  CHECK(unit.count("Service.StartLimitIntervalSec") == 0);
  CHECK(unit.count("Service.StartLimitBurst") == 0);
  // The configuration the service reads is the one ConfigurationDirectory= provides.
  CHECK_THAT(value("Service", "ExecStart"),
             Catch::Contains("--config %E/hvac-twin/hvac-twin.json"));

  // WatchdogSec exceeds twice the wall period of every unit of the example configuration.
  const std::string watchdog = value("Service", "WatchdogSec");
  REQUIRE(watchdog.size() >= 2);
  REQUIRE(watchdog.back() == 's');  // whole seconds, e.g. "30s"
  REQUIRE(watchdog.find_first_not_of("0123456789") == watchdog.size() - 1);
  const double watchdog_s = std::stod(watchdog);
  const auto example = nlohmann::json::parse(
      read_file(std::string(HVAC_TWIN_SOURCE_DIR) + "/config/hvac-twin.example.json"));
  const double scale = example["runtime"].value("time_scale", 1.0);
  for (const auto& u : example["units"]) {
    const double wall_period_s = u["estimator"].value("period_s", 10.0) / scale;
    INFO("unit " << u["id"] << ": wall period " << wall_period_s << " s, WatchdogSec " << watchdog_s
                 << " s");
    CHECK(watchdog_s > 2.0 * wall_period_s);
  }
  // A hung cycle is reported by the daemon itself (exit 70) before systemd's watchdog fires.
  CHECK(example["runtime"].value("hang_timeout_s", 30.0) < watchdog_s);
}

TEST_CASE("the dashboard's unit passes systemd-analyze verify and rates at most 1.5",
          "[integration][systemd][install][web]") {
  const InstallTree tree("web");
  REQUIRE(tree.result.status == 0);
  const RunResult plain = run({"systemd-analyze", "verify", tree.web_unit().string()});
  INFO("verify:\n" << plain.output);
  CHECK(plain.status == 0);
  CHECK(plain.output.empty());
  // With the credentials drop-in in place, as its own comment says to install it.
  const fs::path dropin_dir = tree.unit_dir() / "hvac-twin-web.service.d";
  fs::create_directories(dropin_dir);
  fs::copy_file(tree / "share/doc/hvac_twin/examples/web-credentials.conf",
                dropin_dir / "web-credentials.conf");
  const RunResult with_dropin = run({"systemd-analyze", "verify", tree.web_unit().string()});
  INFO("verify with drop-in:\n" << with_dropin.output);
  CHECK(with_dropin.status == 0);
  CHECK(with_dropin.output.empty());

  const RunResult r = run(
      {"systemd-analyze", "security", "--offline=true", "--no-pager", tree.web_unit().string()});
  INFO(r.output);
  REQUIRE(r.status == 0);
  const double score = exposure(r);
  REQUIRE(score >= 0.0);
  CHECK(score <= 1.5);  // as the daemon's: 1.0 on systemd 252
}

TEST_CASE("the dashboard's unit: loopback by default, no restart on bad input",
          "[integration][systemd][web]") {
  const auto unit =
      parse_unit(std::string(HVAC_TWIN_SOURCE_DIR) + "/systemd/hvac-twin-web.service");
  const auto value = [&](const std::string& section, const std::string& key) {
    const auto it = unit.find(section + "." + key);
    return it == unit.end() || it->second.empty() ? std::string("<missing>") : it->second.back();
  };
  CHECK_THAT(value("Service", "Environment"), Catch::Contains("--listen 127.0.0.1:8080"));
  CHECK(value("Service", "ExecStart") == "/usr/bin/hvac-twin-web $HVAC_TWIN_WEB_OPTIONS");
  CHECK(value("Service", "EnvironmentFile") == "-/etc/hvac-twin/web.env");
  CHECK(value("Service", "RestartPreventExitStatus") == "64 78");
  CHECK(value("Service", "DynamicUser") == "yes");
  CHECK(value("Service", "RestrictAddressFamilies") == "AF_UNIX AF_INET AF_INET6 AF_NETLINK");
  CHECK(value("Service", "IPAddressDeny") == "any");
  CHECK(value("Unit", "StartLimitIntervalSec") != "<missing>");
  CHECK(unit.count("Service.StateDirectory") == 0);  // it keeps nothing on disk
}
