// io/dds/security: credential paths, the Cyclone <Security> fragment, the checks on the files,
// Cyclone's refusal reported with its reason, and hvac-twin-echo's security options.
// (End to end with real CAs: tests/integration/security_dds_test.cpp.)
#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "dds_test_support.hpp"
#include "io/dds/echo/options.hpp"
#include "io/dds/security.hpp"
#include "tests/support/scratch_dir.hpp"

using namespace hvac_twin;
using namespace hvac_twin::dds;

namespace {

constexpr int kDomainRefused = 70;  // 60..79 belong to the service and security tests

namespace fs = std::filesystem;

// Six small files in a fresh directory, named after the fields.
struct SecurityFiles {
  hvac_twin::test::ScratchDir dir;
  config::DdsSecurityConfig config;

  explicit SecurityFiles(const std::string& name) : dir("sec-" + name) {
    config.identity_ca = file("identity_ca.pem");
    config.identity_certificate = file("identity.pem");
    config.private_key = file("identity.key");
    config.permissions_ca = file("permissions_ca.pem");
    config.governance = file("governance.p7s");
    config.permissions = file("permissions.p7s");
  }
  std::string file(const std::string& name) const {
    const std::string path = dir / name;
    std::ofstream(path) << "not really " << name << "\n";
    return path;
  }
};

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "(no exception)";
}

echo::Options parse(std::vector<const char*> args) {
  args.insert(args.begin(), "hvac-twin-echo");
  return echo::parse_options(static_cast<int>(args.size()), args.data());
}

}  // namespace

TEST_CASE("security: ${CREDENTIALS_DIRECTORY} is resolved, other paths kept", "[dds][security]") {
  CHECK(resolve_security_path("f", "/etc/a.pem", nullptr) == "/etc/a.pem");
  CHECK(resolve_security_path("f", "${CREDENTIALS_DIRECTORY}/dds-key", "/run/credentials/x") ==
        "/run/credentials/x/dds-key");
  CHECK_THAT(message_of([] {
               resolve_security_path("dds.security.private_key", "${CREDENTIALS_DIRECTORY}/k",
                                     nullptr);
             }),
             Catch::Contains("dds.security.private_key") &&
                 Catch::Contains("CREDENTIALS_DIRECTORY is not set") &&
                 Catch::Contains("LoadCredential="));
  CHECK_THAT(message_of([] { resolve_security_path("f", "${CREDENTIALS_DIRECTORY}/k", ""); }),
             Catch::Contains("not set"));
  // Whatever the directory is, Cyclone must read the result literally.
  CHECK_THAT(message_of([] { resolve_security_path("f", "${CREDENTIALS_DIRECTORY}/k", "/a$b"); }),
             Catch::Contains("contains"));
}

TEST_CASE("security: the <Security> fragment names every file and the built-in plugins",
          "[dds][security]") {
  const SecurityFiles files("xml");
  const std::string xml = make_security_xml(files.config);
  CHECK(xml.starts_with("<Security>"));
  CHECK(xml.ends_with("</Security>"));
  for (const char* element : {"IdentityCA", "IdentityCertificate", "PrivateKey", "PermissionsCA",
                              "Governance", "Permissions"})
    CHECK_THAT(xml,
               Catch::Contains(std::string("<") + element + ">file:" + files.dir.path().string()));
  for (const char* library : {"dds_security_auth", "dds_security_ac", "dds_security_crypto"})
    CHECK_THAT(xml, Catch::Contains(std::string("path=\"") + library + "\""));

  // Credentials resolve against the environment, as systemd's LoadCredential= sets it.
  config::DdsSecurityConfig via_credentials = files.config;
  via_credentials.private_key = "${CREDENTIALS_DIRECTORY}/identity.key";
  ::setenv("CREDENTIALS_DIRECTORY", files.dir.path().c_str(), 1);
  const std::string resolved = make_security_xml(via_credentials);
  ::unsetenv("CREDENTIALS_DIRECTORY");
  CHECK_THAT(resolved, Catch::Contains("<PrivateKey>file:" + (files.dir / "identity.key") + "<"));
}

TEST_CASE("security: a missing, empty or unreadable file is named at start-up", "[dds][security]") {
  const SecurityFiles files("missing");
  config::DdsSecurityConfig c = files.config;
  c.governance = (files.dir / "nowhere.p7s");
  CHECK_THAT(message_of([&] { make_security_xml(c); }),
             Catch::Contains("cannot read dds.security.governance '" + c.governance + "'") &&
                 Catch::Contains("No such file or directory"));
  c = files.config;
  std::ofstream(c.permissions, std::ios::trunc).close();
  CHECK_THAT(message_of([&] { make_security_xml(c); }),
             Catch::Contains("dds.security.permissions") && Catch::Contains("empty"));
  c = files.config;
  c.identity_ca = files.dir.path().string();
  CHECK_THAT(message_of([&] { make_security_xml(c); }),
             Catch::Contains("dds.security.identity_ca") && Catch::Contains("not a regular file"));
}

TEST_CASE("security: Cyclone's refusal comes with Cyclone's reason", "[dds][security]") {
  const SecurityFiles files("refused");  // present but not certificates at all
  config::DdsConfig dds = dds::test::loopback_config(kDomainRefused);
  dds.security = files.config;
  const std::string message = message_of([&] { (void)make_participant(dds); });
  CHECK_THAT(message, Catch::Contains("cannot create a participant in DDS domain 70"));
  CHECK_THAT(message, Catch::Contains("refused by DDS Security: "));
  CHECK(message.size() > std::string("refused by DDS Security: ").size() + 60);
  // Without security the same configuration works, in the same process.
  dds.security.reset();
  CHECK(make_participant(dds) != nullptr);
}

TEST_CASE("echo: the six security options, all or none", "[dds][security][echo]") {
  const echo::Options none = parse({"--domain", "3"});
  CHECK_FALSE(none.dds.security.has_value());

  const echo::Options all =
      parse({"--identity-ca", "/a/ca.pem", "--identity-certificate", "/a/me.pem", "--private-key",
             "/a/me.key", "--permissions-ca=/a/pca.pem", "--governance", "/a/gov.p7s",
             "--permissions", "/a/perm.p7s"});
  REQUIRE(all.dds.security.has_value());
  CHECK(all.dds.security->identity_ca == "/a/ca.pem");
  CHECK(all.dds.security->identity_certificate == "/a/me.pem");
  CHECK(all.dds.security->private_key == "/a/me.key");
  CHECK(all.dds.security->permissions_ca == "/a/pca.pem");
  CHECK(all.dds.security->governance == "/a/gov.p7s");
  CHECK(all.dds.security->permissions == "/a/perm.p7s");

  CHECK_THROWS_WITH(parse({"--identity-ca", "/a/ca.pem", "--governance", "/a/gov.p7s"}),
                    Catch::Contains("all six") && Catch::Contains("--private-key") &&
                        Catch::Contains("--permissions"));
  CHECK_THROWS_WITH(parse({"--governance", ""}), Catch::Contains("empty path"));
  CHECK_THAT(echo::usage_text(), Catch::Contains("--identity-certificate FILE"));
}
