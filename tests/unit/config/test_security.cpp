// dds.security: present means DDS Security on; six required file paths, each absolute or a
// systemd credential; shape errors at their JSON pointers; the files themselves are not touched.
#include <catch2/catch.hpp>

#include "config_test_support.hpp"

namespace hvac_twin::config {
namespace {

using nlohmann::json;
using test::demo_json;
using test::load;
using test::load_json;
using test::require_single_error;

const char* const kFields[] = {"identity_ca",    "identity_certificate", "private_key",
                               "permissions_ca", "governance",           "permissions"};

json security_json() {
  return {{"identity_ca", "/etc/hvac-twin/dds/identity_ca.pem"},
          {"identity_certificate", "/etc/hvac-twin/dds/hvac-twind.pem"},
          {"private_key", "${CREDENTIALS_DIRECTORY}/dds-identity.key"},
          {"permissions_ca", "/etc/hvac-twin/dds/permissions_ca.pem"},
          {"governance", "/etc/hvac-twin/dds/governance.p7s"},
          {"permissions", "/etc/hvac-twin/dds/hvac-twind-permissions.p7s"}};
}

TEST_CASE("dds.security: absent means off, present means on with every path", "[config]") {
  auto j = demo_json();
  const LoadResult off = load_json(j);
  test::require_ok(off);
  CHECK_FALSE(off.config->dds.security.has_value());

  j["dds"]["security"] = security_json();
  const LoadResult on = load_json(j);
  test::require_ok(on);
  REQUIRE(on.config->dds.security.has_value());
  const DdsSecurityConfig& s = *on.config->dds.security;
  CHECK(s.identity_ca == "/etc/hvac-twin/dds/identity_ca.pem");
  CHECK(s.identity_certificate == "/etc/hvac-twin/dds/hvac-twind.pem");
  CHECK(s.private_key == "${CREDENTIALS_DIRECTORY}/dds-identity.key");  // resolved at start-up
  CHECK(s.permissions_ca == "/etc/hvac-twin/dds/permissions_ca.pem");
  CHECK(s.governance == "/etc/hvac-twin/dds/governance.p7s");
  CHECK(s.permissions == "/etc/hvac-twin/dds/hvac-twind-permissions.p7s");
}

TEST_CASE("dds.security: the loader does not look at the files", "[config]") {
  auto j = demo_json();
  j["dds"]["security"] = security_json();
  j["dds"]["security"]["governance"] = "/nonexistent/governance.p7s";
  test::require_ok(load_json(j));
}

TEST_CASE("dds.security: every field is required", "[config]") {
  for (const char* field : kFields) {
    INFO(field);
    auto j = demo_json();
    j["dds"]["security"] = security_json();
    j["dds"]["security"].erase(field);
    require_single_error(load_json(j), "/dds/security",
                         {"missing required field \"" + std::string(field) + "\""});
  }
}

TEST_CASE("dds.security: paths are absolute or ${CREDENTIALS_DIRECTORY}/<name>", "[config]") {
  struct Bad {
    json value;
    const char* why;
  };
  const Bad bad[] = {
      {"certs/identity_ca.pem", "not an absolute path"},
      {"", "not an absolute path"},
      {"${CREDENTIALS_DIRECTORY}/", "one file name"},
      {"${CREDENTIALS_DIRECTORY}/dds/key.pem", "one file name"},
      {"$CREDENTIALS_DIRECTORY/key.pem", "not an absolute path"},
      {"/etc/$HOME/key.pem", "contains '$'"},
      {"/etc/a<b>.pem", "contains '<'"},
      {"/etc/a&b.pem", "contains '&'"},
      {"/etc/a\\b.pem", "contains '\\'"},
      {"/etc/a\nb.pem", "control character"},
      {"/" + std::string(4100, 'a'), "longer than 4096"},
  };
  for (const auto& b : bad) {
    INFO(b.value.dump());
    auto j = demo_json();
    j["dds"]["security"] = security_json();
    j["dds"]["security"]["private_key"] = b.value;
    require_single_error(
        load_json(j), "/dds/security/private_key",
        {"expected an absolute file path or \"${CREDENTIALS_DIRECTORY}/<name>\"", b.why});
  }
  auto j = demo_json();
  j["dds"]["security"] = security_json();
  j["dds"]["security"]["governance"] = 7;
  require_single_error(load_json(j), "/dds/security/governance", {"expected a string; got 7"});
  // Commas and spaces are fine in a path.
  j["dds"]["security"]["governance"] = "/etc/hvac twin/a,b.p7s";
  test::require_ok(load_json(j));
}

TEST_CASE("dds.security: an object, with known keys only", "[config]") {
  auto j = demo_json();
  j["dds"]["security"] = true;
  require_single_error(load_json(j), "/dds/security", {"expected an object; got true"});
  j["dds"]["security"] = security_json();
  j["dds"]["security"]["governence"] = "/etc/x.p7s";
  require_single_error(load_json(j), "/dds/security/governence",
                       {"unknown key \"governence\"", "did you mean \"governance\"?"});
  j["dds"]["security"].erase("governence");
  j["dds"]["security"]["enabled"] = true;
  require_single_error(load_json(j), "/dds/security/enabled", {"unknown key \"enabled\""});
}

TEST_CASE("the production example configuration is valid and secured", "[config]") {
  const LoadResult r = load(test::read_repo_file("config/hvac-twin.example.json"));
  test::require_ok(r);
  const Config& c = *r.config;
  CHECK(c.state_directory == "/var/lib/hvac-twin");  // StateDirectory=hvac-twin
  CHECK(c.runtime.time_scale == 1.0);
  REQUIRE(c.dds.security.has_value());
  CHECK(c.dds.security->private_key.starts_with("${CREDENTIALS_DIRECTORY}/"));
}

}  // namespace
}  // namespace hvac_twin::config
