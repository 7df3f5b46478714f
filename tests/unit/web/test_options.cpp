// hvac-twin-web's command line (io/web/options.hpp): defaults safe (loopback only), every option,
// and mistakes reported as usage errors naming the option and what was wrong.
#include <catch2/catch.hpp>

#include "io/web/options.hpp"

using namespace hvac_twin::web;

namespace {
Options parse(std::vector<const char*> args) {
  args.insert(args.begin(), "hvac-twin-web");
  return parse_options(static_cast<int>(args.size()), args.data());
}
}  // namespace

TEST_CASE("web options: loopback by default, every option", "[web][options]") {
  const Options d = parse({});
  CHECK(d.listen.host == "127.0.0.1");
  CHECK(d.listen.port == 8080);
  CHECK(d.listen.loopback());
  CHECK_FALSE(d.basic_auth_file);
  CHECK_FALSE(d.token_file);
  CHECK_FALSE(d.tls_certificate);
  CHECK(d.dds.domain_id == 0);
  CHECK(d.dds.interface == "lo");
  CHECK_FALSE(d.dds.allow_multicast);
  CHECK(d.max_clients == 32);
  CHECK(d.history_samples == 720);
  CHECK(d.history_minutes == 1440);

  const Options o = parse({"--listen",
                           "[::1]:9000",
                           "--basic-auth-file",
                           "/etc/u",
                           "--token-file=/etc/t",
                           "--tls-certificate",
                           "/c.pem",
                           "--tls-private-key",
                           "/k.pem",
                           "--allow-host",
                           "gw.example",
                           "--allow-host",
                           "gw",
                           "--max-clients",
                           "10",
                           "--max-units",
                           "50",
                           "--history-samples",
                           "100",
                           "--history-minutes",
                           "60",
                           "--domain",
                           "7",
                           "--interface",
                           "eth1",
                           "--peer",
                           "10.0.0.1",
                           "--topic-prefix",
                           "plant"});
  CHECK(o.listen.host == "::1");
  CHECK(o.listen.port == 9000);
  CHECK(o.listen.loopback());
  CHECK(o.listen.url_host() == "[::1]");
  CHECK(o.basic_auth_file == "/etc/u");
  CHECK(o.token_file == "/etc/t");
  CHECK(o.tls_certificate == "/c.pem");
  CHECK(o.tls_private_key == "/k.pem");
  CHECK(o.allowed_hosts == std::vector<std::string>{"gw.example", "gw"});
  CHECK(o.max_clients == 10);
  CHECK(o.max_units == 50);
  CHECK(o.history_samples == 100);
  CHECK(o.history_minutes == 60);
  // The DDS options are hvac-twin-echo's, parsed by the same code.
  CHECK(o.dds.domain_id == 7);
  CHECK(o.dds.interface == "eth1");
  CHECK(o.dds.peers == std::vector<std::string>{"10.0.0.1"});
  CHECK(o.dds.topic_prefix == "plant");
  CHECK(parse({"--help"}).help);

  CHECK_FALSE(parse_listen("0.0.0.0:80").loopback());
  CHECK(parse_listen("127.1.2.3:0").loopback());
  CHECK(parse_listen("127.1.2.3:0").port == 0);
}

TEST_CASE("web options: mistakes name the option and what was wrong", "[web][options]") {
  using Catch::Contains;
  CHECK_THROWS_WITH(parse({"--listen", "8080"}), Contains("--listen: '8080' is not HOST:PORT"));
  CHECK_THROWS_WITH(parse({"--listen", "localhost:8080"}),
                    Contains("--listen: 'localhost:8080' has no valid IPv4 address"));
  CHECK_THROWS_WITH(parse({"--listen", "127.0.0.1:http"}), Contains("has no valid port"));
  CHECK_THROWS_WITH(parse({"--listen", "127.0.0.1:70000"}), Contains("outside 0..65535"));
  CHECK_THROWS_WITH(parse({"--listen", "[::1]8080"}), Contains("is not [IPv6]:PORT"));
  CHECK_THROWS_WITH(parse({"--listen", "[zz]:8080"}), Contains("no valid IPv6 address"));
  CHECK_THROWS_WITH(parse({"--listen"}), Contains("--listen needs a value"));
  CHECK_THROWS_WITH(parse({"--token-file", ""}), Contains("--token-file: empty path"));
  CHECK_THROWS_WITH(parse({"--tls-certificate", "/c.pem"}),
                    Contains("both --tls-certificate and --tls-private-key"));
  CHECK_THROWS_WITH(parse({"--allow-host", "a:80"}), Contains("--allow-host: 'a:80'"));
  CHECK_THROWS_WITH(parse({"--max-clients", "0"}), Contains("--max-clients: must be 1..1024"));
  CHECK_THROWS_WITH(parse({"--history-samples", "x"}), Contains("'x' is not a number"));
  CHECK_THROWS_WITH(parse({"--domain", "233"}), Contains("--domain: must be 0..232"));
  CHECK_THROWS_WITH(parse({"--governance", "/g.p7s"}), Contains("all six"));
  CHECK_THROWS_WITH(parse({"--topic-prefix", "a/b"}), Contains("a/b"));
  CHECK_THROWS_WITH(parse({"--frobnicate"}), Contains("unknown option '--frobnicate'"));
  CHECK_THROWS_AS(parse({"--frobnicate"}), UsageError);
  CHECK_THAT(usage_text(),
             Contains("--listen HOST:PORT") && Contains("--identity-certificate FILE"));
}
