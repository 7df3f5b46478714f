// Who may read the dashboard: HTTP basic auth against a file of user:password lines, and/or a
// bearer token from a file, and which Host headers the server answers (DNS rebinding).
//
// The files are read once at start-up; under systemd they come through LoadCredential= (the path
// may be "${CREDENTIALS_DIRECTORY}/<name>", or the unit's %d/<name>). With a token, a request is
// allowed with "Authorization: Bearer <token>" (scripts, a reverse proxy) or with basic auth
// whose password is the token, whatever the user name (a browser's own login prompt; EventSource
// cannot send a bearer header). Secrets are compared in constant time.
//
// Threads: load_credentials at start-up; authorize and host_allowed are pure and may be called
// from any thread. Allocation: load_credentials allocates; authorize allocates the decoded
// header.
#pragma once

#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace hvac_twin::web {

struct Credentials {
  std::vector<std::pair<std::string, std::string>> users;  // basic auth: user, password
  std::string token;                                       // empty: no token
  bool required() const noexcept { return !users.empty() || !token.empty(); }
};

// A credentials file that cannot be used; what() names the option, the file and the reason
// (and the line for a basic-auth file).
struct CredentialsError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// The shortest token accepted [characters] (e.g. `openssl rand -hex 32` gives 64).
inline constexpr std::size_t kMinTokenLength = 16;

// Reads --basic-auth-file (lines "user:password"; blank lines and lines starting with '#'
// ignored; the password may contain ':') and --token-file (its first line, surrounding
// whitespace removed, at least kMinTokenLength characters). `credentials_directory` is the
// environment's CREDENTIALS_DIRECTORY (nullptr when unset). Throws CredentialsError.
Credentials load_credentials(const std::optional<std::string>& basic_auth_file,
                             const std::optional<std::string>& token_file,
                             const char* credentials_directory);

enum class Auth { kAllowed, kMissing, kDenied };

// The verdict on a request's Authorization header (empty: none sent).
Auth authorize(const Credentials& credentials, std::string_view authorization);

// Standard base64 (RFC 4648, padding required); nullopt for anything else.
std::optional<std::string> base64_decode(std::string_view text);

// Whether the server answers a request with this Host header: IP literals, "localhost" and the
// names in `allowed` (case-insensitive), with or without a port. A name that is none of these is
// refused: a DNS-rebinding page would send its own domain.
bool host_allowed(std::string_view host_header, const std::vector<std::string>& allowed);

}  // namespace hvac_twin::web
