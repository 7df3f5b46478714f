// Who may read the dashboard (io/web/auth.hpp): the credentials files, the verdict on an
// Authorization header, and the Host check against DNS rebinding.
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>

#include "io/web/auth.hpp"
#include "tests/support/scratch_dir.hpp"

using namespace hvac_twin::web;
using Catch::Contains;

namespace {
std::string write(const std::filesystem::path& p, const std::string& text) {
  std::ofstream(p) << text;
  return p.string();
}
}  // namespace

TEST_CASE("auth: credentials files, read once, with clear errors", "[web][auth]") {
  hvac_twin::test::ScratchDir dir("web-auth");
  const auto users =
      write(dir.path() / "users", "# the operators\nalice:s3cret:with:colons\n\nbob:pw\n");
  const auto token = write(dir.path() / "token", "  0123456789abcdef0123  \nignored\n");
  const Credentials c = load_credentials(users, token, nullptr);
  REQUIRE(c.users.size() == 2);
  CHECK(c.users[0] == std::pair<std::string, std::string>{"alice", "s3cret:with:colons"});
  CHECK(c.users[1].first == "bob");
  CHECK(c.token == "0123456789abcdef0123");
  CHECK(c.required());
  CHECK_FALSE(load_credentials(std::nullopt, std::nullopt, nullptr).required());

  // Through systemd's LoadCredential=: ${CREDENTIALS_DIRECTORY}/name.
  const std::string dir_text = dir.path().string();
  CHECK(load_credentials(std::nullopt, "${CREDENTIALS_DIRECTORY}/token", dir_text.c_str()).token ==
        "0123456789abcdef0123");
  CHECK_THROWS_WITH(load_credentials(std::nullopt, "${CREDENTIALS_DIRECTORY}/token", nullptr),
                    Contains("--token-file") && Contains("CREDENTIALS_DIRECTORY is not set"));

  const auto missing = (dir.path() / "nope").string();
  CHECK_THROWS_WITH(load_credentials(std::nullopt, missing, nullptr),
                    Contains("--token-file: cannot read '" + missing + "': No such file"));
  CHECK_THROWS_WITH(load_credentials(missing, std::nullopt, nullptr),
                    Contains("--basic-auth-file: cannot read"));
  const auto short_token = write(dir.path() / "short", "abc\n");
  CHECK_THROWS_WITH(load_credentials(std::nullopt, short_token, nullptr),
                    Contains("the token has 3 characters; use at least 16"));
  const auto bad = write(dir.path() / "bad", "alice:pw\nbob\n");
  CHECK_THROWS_WITH(load_credentials(bad, std::nullopt, nullptr),
                    Contains(bad + ":2: expected user:password"));
  const auto empty = write(dir.path() / "empty", "# nobody\n");
  CHECK_THROWS_WITH(load_credentials(empty, std::nullopt, nullptr),
                    Contains("no user:password line"));
  CHECK_THROWS_AS(load_credentials(empty, std::nullopt, nullptr), CredentialsError);
}

TEST_CASE("auth: base64 as RFC 4648 has it", "[web][auth]") {
  CHECK(base64_decode("") == "");
  CHECK(base64_decode("Zg==") == "f");
  CHECK(base64_decode("Zm8=") == "fo");
  CHECK(base64_decode("Zm9v") == "foo");
  CHECK(base64_decode("YWxpY2U6czNjcmV0") == "alice:s3cret");
  CHECK_FALSE(base64_decode("Zm9"));  // not a multiple of 4
  CHECK_FALSE(base64_decode("Zm9v!A=="));
  CHECK_FALSE(base64_decode("Z=9v"));  // padding inside
}

TEST_CASE("auth: basic auth, a bearer token, or the token as basic password", "[web][auth]") {
  Credentials open;
  CHECK(authorize(open, "") == Auth::kAllowed);
  CHECK(authorize(open, "Basic garbage") == Auth::kAllowed);

  Credentials c;
  c.users = {{"alice", "s3cret"}};
  c.token = "0123456789abcdef0123";
  CHECK(authorize(c, "") == Auth::kMissing);
  CHECK(authorize(c, "Basic YWxpY2U6czNjcmV0") == Auth::kAllowed);     // alice:s3cret
  CHECK(authorize(c, "basic   YWxpY2U6czNjcmV0 ") == Auth::kAllowed);  // scheme is case-insensitive
  CHECK(authorize(c, "Basic YWxpY2U6d3Jvbmc=") == Auth::kDenied);      // alice:wrong
  CHECK(authorize(c, "Basic Ym9iOnMzY3JldA==") == Auth::kDenied);      // bob:s3cret
  CHECK(authorize(c, "Basic !!!!") == Auth::kDenied);
  CHECK(authorize(c, "Basic YWxpY2U=") == Auth::kDenied);  // no colon
  CHECK(authorize(c, "Bearer 0123456789abcdef0123") == Auth::kAllowed);
  CHECK(authorize(c, "Bearer 0123456789abcdef012") == Auth::kDenied);
  CHECK(authorize(c, "Digest x") == Auth::kDenied);
  // The token as the password of a browser's login prompt, whatever the user name:
  // "anyone:0123456789abcdef0123".
  CHECK(authorize(c, "Basic YW55b25lOjAxMjM0NTY3ODlhYmNkZWYwMTIz") == Auth::kAllowed);
  Credentials users_only;
  users_only.users = {{"alice", "s3cret"}};
  CHECK(authorize(users_only, "Bearer 0123456789abcdef0123") == Auth::kDenied);
  CHECK(authorize(users_only, "Bearer ") == Auth::kDenied);
}

TEST_CASE("auth: the Host header, against DNS rebinding", "[web][auth]") {
  const std::vector<std::string> none;
  CHECK(host_allowed("127.0.0.1:8080", none));
  CHECK(host_allowed("127.0.0.1", none));
  CHECK(host_allowed("[::1]:8080", none));
  CHECK(host_allowed("192.168.1.20:8080", none));
  CHECK(host_allowed("localhost:8080", none));
  CHECK(host_allowed("LocalHost", none));
  CHECK_FALSE(host_allowed("evil.example:8080", none));
  CHECK_FALSE(host_allowed("", none));
  CHECK_FALSE(host_allowed("[nonsense]:80", none));
  CHECK_FALSE(host_allowed("127.0.0.1.evil.example", none));
  const std::vector<std::string> gw{"gateway.plant.example"};
  CHECK(host_allowed("Gateway.Plant.Example:8443", gw));
  CHECK_FALSE(host_allowed("other.plant.example", gw));
}
