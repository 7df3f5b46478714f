#include "io/web/auth.hpp"

#include <arpa/inet.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>

#include "io/dds/security.hpp"

namespace hvac_twin::web {
namespace {

// Reads the whole file at `path` (given as `shown` for option `option`); throws naming them.
std::string read_secret_file(const std::string& option, const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throw CredentialsError(option + ": cannot read '" + path + "': " + std::strerror(errno));
  }
  std::stringstream text;
  text << in.rdbuf();
  if (in.bad()) throw CredentialsError(option + ": cannot read '" + path + "'");
  return text.str();
}

std::string resolve(const std::string& option, const std::string& path, const char* directory) {
  try {
    return dds::resolve_security_path(option, path, directory);
  } catch (const std::runtime_error& e) {
    throw CredentialsError(e.what());
  }
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front())))
    s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back())))
    s.remove_suffix(1);
  return s;
}

// Equal, in time that depends only on the lengths.
bool same(std::string_view a, std::string_view b) noexcept {
  unsigned diff = a.size() == b.size() ? 0u : 1u;
  const std::size_t n = std::max(a.size(), b.size());
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char x = i < a.size() ? static_cast<unsigned char>(a[i]) : 0;
    const unsigned char y = i < b.size() ? static_cast<unsigned char>(b[i]) : 0;
    diff |= static_cast<unsigned>(x ^ y);
  }
  return diff == 0;
}

bool starts_with_nocase(std::string_view text, std::string_view prefix) {
  return text.size() >= prefix.size() &&
         std::equal(prefix.begin(), prefix.end(), text.begin(), [](char a, char b) {
           return std::tolower(static_cast<unsigned char>(a)) ==
                  std::tolower(static_cast<unsigned char>(b));
         });
}

bool equal_nocase(std::string_view a, std::string_view b) {
  return a.size() == b.size() && starts_with_nocase(a, b);
}

}  // namespace

Credentials load_credentials(const std::optional<std::string>& basic_auth_file,
                             const std::optional<std::string>& token_file,
                             const char* credentials_directory) {
  Credentials c;
  if (basic_auth_file) {
    const std::string option = "--basic-auth-file";
    const std::string path = resolve(option, *basic_auth_file, credentials_directory);
    const std::string text = read_secret_file(option, path);
    std::istringstream lines(text);
    std::string line;
    for (int number = 1; std::getline(lines, line); ++number) {
      const std::string_view l = trim(line);
      if (l.empty() || l.front() == '#') continue;
      const std::size_t colon = l.find(':');
      if (colon == std::string_view::npos || colon == 0 || colon + 1 == l.size()) {
        throw CredentialsError(option + ": " + path + ":" + std::to_string(number) +
                               ": expected user:password (both non-empty)");
      }
      c.users.emplace_back(std::string(l.substr(0, colon)), std::string(l.substr(colon + 1)));
    }
    if (c.users.empty()) throw CredentialsError(option + ": " + path + ": no user:password line");
  }
  if (token_file) {
    const std::string option = "--token-file";
    const std::string path = resolve(option, *token_file, credentials_directory);
    const std::string text = read_secret_file(option, path);
    const std::string_view token = trim(std::string_view(text).substr(0, text.find('\n')));
    if (token.size() < kMinTokenLength) {
      throw CredentialsError(option + ": " + path + ": the token has " +
                             std::to_string(token.size()) + " characters; use at least " +
                             std::to_string(kMinTokenLength) + " (e.g. openssl rand -hex 32)");
    }
    c.token = token;
  }
  return c;
}

std::optional<std::string> base64_decode(std::string_view text) {
  if (text.size() % 4 != 0) return std::nullopt;
  std::string out;
  out.reserve(text.size() / 4 * 3);
  unsigned buffer = 0;
  int bits = 0;
  std::size_t padding = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char ch = text[i];
    int v = -1;
    if (ch >= 'A' && ch <= 'Z')
      v = ch - 'A';
    else if (ch >= 'a' && ch <= 'z')
      v = ch - 'a' + 26;
    else if (ch >= '0' && ch <= '9')
      v = ch - '0' + 52;
    else if (ch == '+')
      v = 62;
    else if (ch == '/')
      v = 63;
    else if (ch == '=' && i + 2 >= text.size())
      v = -2;
    if (v == -1) return std::nullopt;
    if (v == -2) {
      ++padding;
      continue;
    }
    if (padding > 0) return std::nullopt;  // data after padding
    buffer = (buffer << 6) | static_cast<unsigned>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((buffer >> bits) & 0xFFu);
    }
  }
  return out;
}

Auth authorize(const Credentials& credentials, std::string_view authorization) {
  if (!credentials.required()) return Auth::kAllowed;
  authorization = trim(authorization);
  if (authorization.empty()) return Auth::kMissing;
  bool ok = false;
  if (starts_with_nocase(authorization, "Bearer ")) {
    const std::string_view token = trim(authorization.substr(7));
    ok = !credentials.token.empty() && same(token, credentials.token);
  } else if (starts_with_nocase(authorization, "Basic ")) {
    const auto decoded = base64_decode(trim(authorization.substr(6)));
    if (!decoded) return Auth::kDenied;
    const std::size_t colon = decoded->find(':');
    if (colon == std::string::npos) return Auth::kDenied;
    const std::string_view user = std::string_view(*decoded).substr(0, colon);
    const std::string_view password = std::string_view(*decoded).substr(colon + 1);
    // Every entry compared, whatever matched before, both fields of each: no early exit.
    for (const auto& [u, p] : credentials.users) {
      const bool user_ok = same(user, u);
      const bool password_ok = same(password, p);
      ok = (user_ok && password_ok) || ok;
    }
    if (!credentials.token.empty()) {
      const bool token_ok = same(password, credentials.token);
      ok = token_ok || ok;
    }
  }
  return ok ? Auth::kAllowed : Auth::kDenied;
}

bool host_allowed(std::string_view host, const std::vector<std::string>& allowed) {
  host = trim(host);
  if (host.empty()) return false;
  std::string name;
  if (host.front() == '[') {  // [IPv6]:port
    const std::size_t close = host.find(']');
    if (close == std::string_view::npos) return false;
    name = host.substr(1, close - 1);
    in6_addr v6{};
    return inet_pton(AF_INET6, name.c_str(), &v6) == 1;
  }
  name = host.substr(0, host.find(':'));
  in_addr v4{};
  if (inet_pton(AF_INET, name.c_str(), &v4) == 1) return true;
  if (equal_nocase(name, "localhost")) return true;
  return std::any_of(allowed.begin(), allowed.end(),
                     [&](const std::string& a) { return equal_nocase(name, a); });
}

}  // namespace hvac_twin::web
