// DDS Security end to end, with throw-away CAs, identities and signed documents made by openssl
// from the templates in io/dds/security/:
//  - the daemon (its files handed over as systemd credentials) publishes to a permitted
//    subscriber; a participant with an identity from another CA and an unauthenticated one
//    receive nothing;
//  - topic names, type names and values never cross the loopback in plaintext, while without
//    DDS Security the same capture finds them (so the check can fail);
//  - a tampered governance document, expired permissions, a missing file or an unresolvable
//    ${CREDENTIALS_DIRECTORY} stop start-up with a clear message and without READY=1;
//  - hvac-twin-web with the subscriber's identity (its files through ${CREDENTIALS_DIRECTORY})
//    shows the secured daemon's unit; one without DDS Security shows nothing.
// The network tests run in a private network namespace: the capture sees only this test.
#include <httplib.h>

#include <catch2/catch.hpp>
#include <filesystem>

#include "tests/integration/security_capture.hpp"
#include "tests/integration/security_pki.hpp"
#include "tests/integration/stack.hpp"
#include "tests/support/notify_socket.hpp"

using namespace hvac_twin::test;
using namespace std::chrono_literals;

namespace {

// Distinctive strings, so that finding one in a captured frame cannot be a coincidence.
constexpr const char* kPrefix = "plantroom7";
constexpr const char* kSite = "site-f3a9c1";

std::size_t line_count(const std::string& file) {
  std::ifstream in(file);
  std::size_t n = 0;
  std::string line;
  while (std::getline(in, line))
    if (!line.empty()) ++n;
  return n;
}

bool has_topic(const std::string& file, const std::string& topic) {
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line))
    if (line.find("\"topic\":\"" + topic + "\"") != std::string::npos) return true;
  return false;
}

nlohmann::json security_json(const hvac_twin::config::DdsSecurityConfig& s) {
  return {{"identity_ca", s.identity_ca}, {"identity_certificate", s.identity_certificate},
          {"private_key", s.private_key}, {"permissions_ca", s.permissions_ca},
          {"governance", s.governance},   {"permissions", s.permissions}};
}

std::unique_ptr<Process> start_echo(const Stack& stack, const std::string& name,
                                    std::vector<std::string> extra) {
  std::vector<std::string> args{"--domain",       std::to_string(stack.options().domain_id),
                                "--topic-prefix", kPrefix,
                                "--format",       "json"};
  args.insert(args.end(), extra.begin(), extra.end());
  return std::make_unique<Process>(HVAC_TWIN_ECHO_EXE, args, stack.path(name + ".jsonl"),
                                   stack.path(name + ".err"));
}

}  // namespace

TEST_CASE(
    "DDS Security: only the permitted subscriber receives, and nothing readable crosses "
    "the wire",
    "[integration][security]") {
  const std::string netns = enter_private_network();
  INFO(netns);
  REQUIRE(netns.empty());
  LoopbackCapture capture;
  INFO(capture.error());
  REQUIRE(capture.error().empty());

  StackOptions o = zone_stack_options(74);
  // The daemon's files come as systemd's LoadCredential= would hand them over, under the names
  // of systemd/dds-security.conf, in a directory named by CREDENTIALS_DIRECTORY.
  o.customize = [](nlohmann::json& c) {
    c["site_id"] = kSite;
    c["dds"]["topic_prefix"] = kPrefix;
    c["dds"]["security"] = {{"identity_ca", "${CREDENTIALS_DIRECTORY}/dds-identity-ca.pem"},
                            {"identity_certificate", "${CREDENTIALS_DIRECTORY}/dds-identity.pem"},
                            {"private_key", "${CREDENTIALS_DIRECTORY}/dds-identity.key"},
                            {"permissions_ca", "${CREDENTIALS_DIRECTORY}/dds-permissions-ca.pem"},
                            {"governance", "${CREDENTIALS_DIRECTORY}/dds-governance.p7s"},
                            {"permissions", "${CREDENTIALS_DIRECTORY}/dds-permissions.p7s"}};
  };
  Stack stack("security", o);
  const TestPki pki(stack.path("pki"), o.domain_id, kPrefix);
  const std::filesystem::path credentials = stack.path("credentials");
  std::filesystem::create_directories(credentials);
  const auto daemon = pki.security("daemon");
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {daemon.identity_ca, "dds-identity-ca.pem"},
           {daemon.identity_certificate, "dds-identity.pem"},
           {daemon.private_key, "dds-identity.key"},
           {daemon.permissions_ca, "dds-permissions-ca.pem"},
           {daemon.governance, "dds-governance.p7s"},
           {daemon.permissions, "dds-permissions.p7s"}})
    std::filesystem::copy_file(from, credentials / to);

  stack.start_sim();
  auto systemd = std::make_unique<NotifySocket>();
  stack.start_daemon(
      {}, {"NOTIFY_SOCKET=" + systemd->path(), "CREDENTIALS_DIRECTORY=" + credentials.string()});
  INFO("daemon log:\n" << stack.daemon().err());
  REQUIRE(!systemd->receive(10s, "READY=1").empty());
  CHECK_THAT(stack.daemon().err(), Catch::Contains("DDS Security on"));
  // Nobody reads the socket from here on: remove it, so that sd_notify fails at once instead of
  // blocking once the socket's queue (net.unix.max_dgram_qlen, 10 here) is full.
  systemd.reset();

  // The rogue holds a certificate with the permitted subscriber's very subject, issued by a CA
  // it trusts but the daemon does not, and the genuine (public) signed documents.
  auto permitted = start_echo(stack, "permitted", TestPki::echo_args(pki.security("subscriber")));
  auto rogue = start_echo(stack, "rogue",
                          TestPki::echo_args(pki.security("rogue", "other_ca", "subscriber")));
  const std::string permitted_out = stack.path("permitted.jsonl");
  const bool all_topics = eventually(
      [&] {
        return has_topic(permitted_out, "virtual_sensor") &&
               has_topic(permitted_out, "observation") &&
               has_topic(permitted_out, "estimator_health");
      },
      20s);
  INFO("permitted subscriber: " << Process::read(stack.path("permitted.err")));
  REQUIRE(all_topics);
  // Some 6 more cycles (3 s) with the rogue present: it retries the handshake every second.
  const std::size_t seen = line_count(permitted_out);
  REQUIRE(eventually([&] { return line_count(permitted_out) >= seen + 36; }, 15s));
  const unsigned drops = capture.stop();
  capture.write_pcap(stack.path("secure-loopback.pcap"));

  INFO("rogue log:\n" << Process::read(stack.path("rogue.err")));
  CHECK(rogue->running());  // it runs, discovers the daemon, and is refused in the handshake
  CHECK(line_count(stack.path("rogue.jsonl")) == 0);

  // The capture is whole and holds the session: RTPS frames, certificates exchanged in the
  // handshake (identity subjects are public by design), and not one readable name or value.
  INFO("capture: " << capture.frames() << " frames, " << capture.frames_containing("RTPS")
                   << " RTPS, pcap " << stack.path("secure-loopback.pcap"));
  CHECK(drops == 0);
  CHECK(capture.frames_containing("RTPS") >= 50);
  CHECK(capture.frames_containing("hvac-twin-test") > 0);
  const std::string prefix = kPrefix;
  for (const std::string& needle :
       {prefix + "/virtual_sensor", prefix + "/observation", prefix + "/estimator_health",
        std::string("virtual_sensor"), std::string("observation"), std::string("estimator_health"),
        std::string("VirtualSensor"), std::string("Observation"), std::string("EstimatorHealth"),
        std::string(kSite), std::string("zone1"), std::string("zone_temp"), std::string("degC")}) {
    INFO("needle " << needle);
    CHECK(capture.frames_containing(needle) == 0);
  }
  // The topic prefix appears in one place only: the grant of a permissions document, which the
  // DDS Security authentication handshake carries signed but unencrypted ("<prefix>/*").
  CHECK(capture.occurrences(kPrefix) == capture.occurrences("<topic>" + prefix + "/*</topic>"));

  // An unauthenticated participant (no DDS Security at all) gets nothing either, while the
  // permitted subscriber keeps receiving.
  auto plain = start_echo(stack, "unauthenticated", {});
  const std::size_t before = line_count(permitted_out);
  REQUIRE(eventually([&] { return line_count(permitted_out) >= before + 30; }, 10s));
  CHECK(plain->running());
  CHECK(line_count(stack.path("unauthenticated.jsonl")) == 0);

  stack.daemon().signal(SIGTERM);
  const auto rc = stack.daemon().wait(5s);
  REQUIRE(rc.has_value());
  CHECK(*rc == 0);
}

TEST_CASE("without DDS Security the same capture reads the topic names on loopback",
          "[integration][security]") {
  const std::string netns = enter_private_network();
  INFO(netns);
  REQUIRE(netns.empty());
  LoopbackCapture capture;
  REQUIRE(capture.error().empty());
  StackOptions o = zone_stack_options(64);
  o.customize = [](nlohmann::json& c) {
    c["site_id"] = kSite;
    c["dds"]["topic_prefix"] = kPrefix;
  };
  Stack stack("plaintext", o);
  stack.start_sim();
  stack.start_daemon();
  auto echo = start_echo(stack, "echo", {});
  REQUIRE(eventually([&] { return has_topic(stack.path("echo.jsonl"), "estimator_health"); }, 20s));
  capture.stop();
  capture.write_pcap(stack.path("plain-loopback.pcap"));
  INFO("capture: " << capture.frames() << " frames");
  CHECK(capture.frames_containing(std::string(kPrefix) + "/virtual_sensor") > 0);
  CHECK(capture.frames_containing(kSite) > 0);
}

TEST_CASE("bad DDS Security material stops start-up with a clear error",
          "[integration][security]") {
  StackOptions o = zone_stack_options(65);
  Stack stack("security-bad", o);
  const TestPki pki(stack.path("pki"), o.domain_id, kPrefix);
  auto security = pki.security("daemon");
  std::vector<std::string> env;
  std::vector<std::string> expected;

  SECTION("a tampered governance document") {
    security.governance = pki.path("governance_tampered.p7s");
    expected = {"refused by DDS Security", "does not verify against permissions_ca",
                "signature failure"};
  }
  SECTION("expired permissions") {
    security.permissions = pki.path("daemon_expired_permissions.p7s");
    expected = {"refused by DDS Security", "the permissions document has expired",
                "validity period expired"};
  }
  SECTION("permissions for another identity") {
    security.permissions = pki.path("subscriber_permissions.p7s");
    expected = {"refused by DDS Security", "grants another subject"};
  }
  SECTION("a missing file") {
    security.private_key = pki.path("nowhere.key");
    expected = {"cannot read dds.security.private_key", "No such file or directory"};
  }
  SECTION("a credential outside systemd") {
    security.private_key = "${CREDENTIALS_DIRECTORY}/dds-identity.key";
    env.push_back("CREDENTIALS_DIRECTORY=");
    expected = {"dds.security.private_key", "CREDENTIALS_DIRECTORY is not set"};
  }

  o.customize = [&](nlohmann::json& c) {
    c["dds"]["security"] = security_json(security);
    c["units"][0]["modbus"]["port"] = 1;  // never reached: DDS comes first
  };
  Stack run("security-bad-run", o);
  NotifySocket systemd;
  env.push_back("NOTIFY_SOCKET=" + systemd.path());
  run.start_daemon({}, env);
  const auto rc = run.daemon().wait(10s);
  const std::string err = run.daemon().err();
  INFO("daemon log:\n" << err);
  REQUIRE(rc.has_value());
  CHECK(*rc == 1);
  CHECK_THAT(err, Catch::Contains("start-up failed"));
  for (const auto& words : expected)
    CHECK_THAT(err, Catch::Contains(words));
  const auto notes = systemd.receive(200ms);
  CHECK(std::find(notes.begin(), notes.end(), "READY=1") == notes.end());
}

TEST_CASE("DDS Security: hvac-twin-web with a subscriber's identity shows the secured unit",
          "[integration][security][web]") {
  constexpr int kDomain = 205;  // hvac-twin-web's range (200..209)
  const hvac_twin::test::ScratchDir pki_dir("security-web-pki");
  const TestPki pki(pki_dir.path(), kDomain, kPrefix);
  StackOptions o = zone_stack_options(kDomain);
  o.customize = [&](nlohmann::json& c) {
    c["dds"]["topic_prefix"] = kPrefix;
    c["dds"]["security"] = security_json(pki.security("daemon"));
  };
  Stack secured("security-web", o);
  secured.start_sim();
  secured.start_daemon();
  // The web's six files as LoadCredential= hands them over (a drop-in like dds-security.conf):
  // through ${CREDENTIALS_DIRECTORY}, which hvac-twin-web resolves like the daemon.
  const std::filesystem::path credentials = secured.path("web-credentials");
  std::filesystem::create_directories(credentials);
  std::vector<std::string> args{
      "--domain", std::to_string(kDomain), "--topic-prefix", kPrefix, "--listen", "127.0.0.1:0"};
  const auto subscriber = pki.security("subscriber");
  const std::vector<std::pair<std::string, std::string>> files{
      {"--identity-ca", subscriber.identity_ca},
      {"--identity-certificate", subscriber.identity_certificate},
      {"--private-key", subscriber.private_key},
      {"--permissions-ca", subscriber.permissions_ca},
      {"--governance", subscriber.governance},
      {"--permissions", subscriber.permissions}};
  for (const auto& [option, file] : files) {
    const std::string name = option.substr(2);
    std::filesystem::copy_file(file, credentials / name);
    args.insert(args.end(), {option, "${CREDENTIALS_DIRECTORY}/" + name});
  }
  Process web(HVAC_TWIN_WEB_EXE, args, secured.path("web.out"), secured.path("web.err"),
              {"CREDENTIALS_DIRECTORY=" + credentials.string()});
  Process plain(
      HVAC_TWIN_WEB_EXE,
      {"--domain", std::to_string(kDomain), "--topic-prefix", kPrefix, "--listen", "127.0.0.1:0"},
      secured.path("plain.out"), secured.path("plain.err"));
  const auto port_of = [](Process& p) {
    std::optional<std::vector<std::string>> m;
    const bool up = eventually(
        [&] {
          return (m = regex_find(p.err(), R"(serving http://127\.0\.0\.1:(\d+)/)")).has_value();
        },
        20s);
    return up ? std::stoi((*m)[1]) : 0;
  };
  const int web_port = port_of(web), plain_port = port_of(plain);
  INFO("secured hvac-twin-web:\n"
       << web.err() << "\nplain:\n"
       << plain.err() << "\ndaemon:\n"
       << secured.daemon().err());
  REQUIRE(web_port > 0);
  REQUIRE(plain_port > 0);
  CHECK_THAT(web.err(), Catch::Contains("DDS Security on"));
  const auto units = [](int port) {
    httplib::Client http("127.0.0.1", port);
    http.set_read_timeout(5, 0);
    const auto r = http.Get("/api/overview");
    return r && r->status == 200 ? nlohmann::json::parse(r->body)["units"] : nlohmann::json();
  };
  nlohmann::json shown;
  REQUIRE(eventually([&] { return (shown = units(web_port)).size() == 1; }, 30s));
  CHECK(shown[0]["unit"] == "zone1");
  // Some cycles later the participant without DDS Security still has nothing.
  std::this_thread::sleep_for(3s);
  CHECK(units(plain_port).empty());
  CHECK(units(web_port)[0]["health"]["cycle"] > shown[0]["health"]["cycle"]);
}
