// Participant: the generated Cyclone configuration, domain sharing, clear creation errors.
#include <catch2/catch.hpp>
#include <string>

#include "dds_test_support.hpp"
#include "io/dds/participant.hpp"

using namespace hvac_twin;
using namespace hvac_twin::dds;

namespace {
constexpr int kDomainShare = 101;
constexpr int kDomainErrors = 102;
constexpr int kDomainExtraXml = 115;

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}
}  // namespace

TEST_CASE("cyclone config pins the interface, multicast and peers", "[dds][participant]") {
  config::DdsConfig config;  // defaults: lo, multicast off, peer 127.0.0.1
  std::string xml = make_cyclone_config(config);
  CHECK(contains(xml, "<NetworkInterface name=\"lo\"/>"));
  CHECK(contains(xml, "<AllowMulticast>false</AllowMulticast>"));
  CHECK(contains(xml, "<Peers><Peer address=\"127.0.0.1\"/></Peers>"));
  CHECK(contains(xml, "<MaxAutoParticipantIndex>" + std::to_string(kMaxParticipantsPerHost - 1) +
                          "</MaxAutoParticipantIndex>"));
  CHECK(contains(xml, "<ParticipantIndex>auto</ParticipantIndex>"));

  config.interface = "eth1";
  config.allow_multicast = true;
  config.peers = {"10.0.0.2", "gateway-2.local:7410"};
  xml = make_cyclone_config(config);
  CHECK(contains(xml, "<NetworkInterface name=\"eth1\"/>"));
  CHECK(contains(xml, "<AllowMulticast>true</AllowMulticast>"));
  CHECK(contains(xml, "<Peer address=\"10.0.0.2\"/><Peer address=\"gateway-2.local:7410\"/>"));
}

TEST_CASE("cyclone config refuses what would break or inject XML", "[dds][participant]") {
  config::DdsConfig config;
  config.interface = "lo\"/><Bad";
  CHECK_THROWS_AS(make_cyclone_config(config), std::invalid_argument);
  config.interface = "";
  CHECK_THROWS_AS(make_cyclone_config(config), std::invalid_argument);
  config.interface = "lo";
  config.peers = {"127.0.0.1<"};
  CHECK_THROWS_AS(make_cyclone_config(config), std::invalid_argument);
  config.peers.clear();
  CHECK_THROWS_AS(make_cyclone_config(config), std::invalid_argument);  // no way to discover
  config.allow_multicast = true;
  CHECK_NOTHROW(make_cyclone_config(config));
}

TEST_CASE("participants of one process share a domain with the same configuration",
          "[dds][participant]") {
  const config::DdsConfig config = test::loopback_config(kDomainShare);
  {
    Participant a(config);
    Participant b(config);
    CHECK(a.domain_id() == kDomainShare);
    CHECK(a.native_handle() > 0);
    CHECK(b.native_handle() > 0);
    CHECK(a.native_handle() != b.native_handle());

    config::DdsConfig other = config;
    other.peers = {"127.0.0.2"};
    try {
      Participant c(other);
      FAIL("a second configuration for the same domain was accepted");
    } catch (const std::runtime_error& e) {
      CHECK(contains(e.what(), "domain 101"));
      CHECK(contains(e.what(), "different configuration"));
    }
  }
  // The last participant took the domain with it: a new configuration is fine now.
  config::DdsConfig other = config;
  other.peers = {"127.0.0.1", "127.0.0.2"};
  CHECK_NOTHROW(Participant(other));
}

TEST_CASE("participant creation errors name the domain and the interface", "[dds][participant]") {
  config::DdsConfig config = test::loopback_config(kDomainErrors);
  config.domain_id = 233;
  CHECK_THROWS_AS(Participant(config), std::invalid_argument);
  config.domain_id = -1;
  CHECK_THROWS_AS(Participant(config), std::invalid_argument);

  config.domain_id = kDomainErrors;
  config.interface = "hvacnoif0";
  try {
    Participant p(config);
    FAIL("a participant on a missing interface was created");
  } catch (const std::runtime_error& e) {
    CHECK(contains(e.what(), "domain 102"));
    CHECK(contains(e.what(), "'hvacnoif0'"));
  }
  // The failed attempt left nothing behind: the right configuration works.
  CHECK_NOTHROW(Participant(test::loopback_config(kDomainErrors)));
}

TEST_CASE("extra Cyclone XML is applied after the generated settings", "[dds][participant]") {
  const config::DdsConfig config = test::loopback_config(kDomainExtraXml);
  CHECK_NOTHROW(Participant(config, "<Tracing><Verbosity>warning</Verbosity></Tracing>"));
  CHECK_THROWS_AS(Participant(config, "<NoSuchElement/>"), std::runtime_error);
  CHECK_NOTHROW(Participant(config));  // the failed attempt left nothing behind
}
