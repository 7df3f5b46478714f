// The built hvac-twin-web: its exit codes and messages for bad input, and, against real Cyclone
// DDS writers on loopback (UnitPublisher, as the daemon publishes), the page's data over HTTP and
// the event stream: a sample appears at once, a publisher that stops turns its unit stale.
#include <httplib.h>

#include <catch2/catch.hpp>
#include <chrono>
#include <csignal>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <thread>

#include "io/dds/participant.hpp"
#include "io/dds/publisher.hpp"
#include "tests/support/scratch_dir.hpp"
#include "tests/unit/dds/dds_test_support.hpp"

using namespace hvac_twin;
using namespace std::chrono_literals;
using Catch::Contains;
using dds::test::ChildProcess;

namespace {

constexpr int kDomainWeb = 202;  // hvac-twin-web's range (200..209)

struct Run {
  int status;
  std::string err;
};

Run run(std::vector<std::string> args) {
  args.insert(args.begin(), HVAC_TWIN_WEB_EXE);
  ChildProcess p(args);
  const int status = p.wait(20s);
  return {status, p.stderr_text()};
}

// The port the started binary reports ("serving http://127.0.0.1:PORT/").
int served_port(ChildProcess& web) {
  REQUIRE(web.wait_for_stderr("/ (DDS domain", 20s));
  std::smatch m;
  const std::string err = web.stderr_text();
  REQUIRE(std::regex_search(err, m, std::regex(R"(serving http://127\.0\.0\.1:(\d+)/)")));
  return std::stoi(m[1].str());
}

}  // namespace

TEST_CASE("hvac-twin-web: bad input is named, with the exit codes of hvac-twin-echo",
          "[web][binary]") {
  hvac_twin::test::ScratchDir dir("web-binary");
  const Run help = run({"--help"});
  CHECK(help.status == 0);
  const Run listen = run({"--listen", "127.0.0.1"});
  CHECK(listen.status == 64);
  CHECK_THAT(listen.err, Contains("hvac-twin-web: --listen: '127.0.0.1' is not HOST:PORT"));
  const Run unknown = run({"--bogus"});
  CHECK(unknown.status == 64);
  CHECK_THAT(unknown.err, Contains("unknown option '--bogus'"));
  const Run domain = run({"--domain", "999"});
  CHECK(domain.status == 64);
  // Files that cannot be used: 78 (EX_CONFIG), before any socket or DDS.
  const std::string missing = dir / "token";
  const Run token = run({"--token-file", missing});
  CHECK(token.status == 78);
  CHECK_THAT(token.err, Contains("--token-file: cannot read '" + missing + "'"));
  std::ofstream(dir / "cert.pem") << "not a certificate\n";
  std::ofstream(dir / "key.pem") << "not a key\n";
  const Run tls = run({"--listen", "127.0.0.1:0", "--tls-certificate", dir / "cert.pem",
                       "--tls-private-key", dir / "key.pem"});
  CHECK(tls.status == 78);
  CHECK_THAT(tls.err, Contains("OpenSSL refused the certificate"));
  // A port that is taken: 1, naming it.
  ChildProcess first({HVAC_TWIN_WEB_EXE, "--domain", std::to_string(kDomainWeb), "--listen",
                      "127.0.0.1:0", "--topic-prefix", "hvac_twin_web_taken"});
  const int port = served_port(first);
  const Run taken = run(
      {"--domain", std::to_string(kDomainWeb), "--listen", "127.0.0.1:" + std::to_string(port)});
  CHECK(taken.status == 1);
  CHECK_THAT(taken.err, Contains("cannot listen on 127.0.0.1:" + std::to_string(port) +
                                 ": Address already in use"));
  first.send_signal(SIGTERM);
  CHECK(first.wait(10s) == 0);
}

TEST_CASE(
    "hvac-twin-web: real DDS samples reach the API and the stream, and a silent publisher "
    "turns stale",
    "[web][binary][dds]") {
  const config::DdsConfig dds_config = dds::test::loopback_config(kDomainWeb);
  ChildProcess web({HVAC_TWIN_WEB_EXE, "--domain", std::to_string(kDomainWeb), "--listen",
                    "127.0.0.1:0", "--topic-prefix", dds_config.topic_prefix});
  const int port = served_port(web);
  dds::Participant participant(dds_config);
  constexpr auto kPeriod = 100ms;  // deadline 250 ms, lease 300 ms
  dds::UnitPublisher publisher(participant, dds_config.topic_prefix, "site", "hp1", kPeriod);
  const auto publish_cycle = [&](std::uint64_t cycle) {
    dds::HealthSample h;
    h.cycle = cycle;
    h.quality = dds::EstimateQuality::kGood;
    h.modbus_connected = true;
    h.timestamp_ns = dds::test::now_ns();
    REQUIRE(publisher.publish(h) == dds::PublishStatus::kOk);
    dds::LeakDiagnosticSample l;
    l.state = cycle < 10 ? dds::LeakState::kNormal : dds::LeakState::kLeak;
    l.hold = dds::LeakHold::kNone;
    l.charge = 0.4;
    l.nameplate_charge = 0.5;
    l.threshold = 6.9;
    l.quality = dds::EstimateQuality::kGood;
    l.timestamp_ns = h.timestamp_ns;
    l.cycle = cycle;
    REQUIRE(publisher.publish(l) == dds::PublishStatus::kOk);
  };
  httplib::Client http("127.0.0.1", port);
  http.set_read_timeout(10, 0);
  std::uint64_t cycle = 1;
  nlohmann::json overview;
  REQUIRE(dds::test::eventually([&] {
    publish_cycle(cycle++);
    std::this_thread::sleep_for(kPeriod);
    overview = nlohmann::json::parse(http.Get("/api/overview")->body);
    return overview["units"].size() == 1;
  }));
  CHECK(overview["units"][0]["unit"] == "hp1");
  CHECK(overview["units"][0]["leak"]["state"] == "NORMAL");
  CHECK(overview["units"][0]["stale"] == "NO");

  // The overview stream: the LEAK summary arrives once published, then the stale one once the
  // publisher stops.
  std::string stream;
  std::atomic<bool> hello{false}, leak_seen{false}, stale_seen{false};
  std::atomic<std::int64_t> leak_at{0}, stale_at{0};
  std::thread reader([&] {
    httplib::Client c("127.0.0.1", port);
    c.set_read_timeout(30, 0);
    c.Get("/events", [&](const char* data, std::size_t n) {
      stream.append(data, n);
      const auto now = std::chrono::steady_clock::now().time_since_epoch().count();
      hello = stream.find("event: hello") != std::string::npos;
      if (!leak_seen && stream.find("\"state\":\"LEAK\"") != std::string::npos) {
        leak_seen = true;
        leak_at = now;
      }
      if (!stale_seen && (stream.find("\"stale\":\"DEADLINE_MISSED\"") != std::string::npos ||
                          stream.find("\"stale\":\"LIVELINESS_LOST\"") != std::string::npos)) {
        stale_seen = true;
        stale_at = now;
      }
      return !stale_seen;
    });
  });
  REQUIRE(dds::test::eventually([&] { return hello.load(); }));
  while (cycle < 10) {
    publish_cycle(cycle++);
    std::this_thread::sleep_for(kPeriod);
  }
  const auto leak_published = std::chrono::steady_clock::now().time_since_epoch().count();
  publish_cycle(cycle++);  // LEAK
  REQUIRE(dds::test::eventually([&] { return leak_seen.load(); }, 5s));
  const double leak_ms = static_cast<double>(leak_at - leak_published) / 1e6;
  INFO("LEAK published to the stream: " << leak_ms << " ms");
  CHECK(leak_ms < 1000.0);  // the aim: on the page within 1 s

  // The publisher stops: stale within the deadline (250 ms) or the lease (300 ms), plus the
  // check's granularity.
  const auto stopped = std::chrono::steady_clock::now().time_since_epoch().count();
  REQUIRE(dds::test::eventually([&] { return stale_seen.load(); }, 5s));
  reader.join();
  const double stale_ms = static_cast<double>(stale_at - stopped) / 1e6;
  INFO("stale " << stale_ms << " ms after the last sample");
  CHECK(stale_ms < 300.0 + 300.0);
  web.send_signal(SIGTERM);
  CHECK(web.wait(10s) == 0);
}
