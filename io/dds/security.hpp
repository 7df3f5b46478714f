// DDS Security for the hvac-twin participants: the Cyclone DDS <Security> configuration built from
// config::DdsSecurityConfig, and the participant factory that the daemon and hvac-twin-echo use.
//
// Cyclone's built-in plugins (libdds_security_auth, _ac, _crypto; in Debian's libddsc0debian) do
// the work: X.509 authentication against the identity CA, governance and permissions documents
// signed by the permissions CA, AES-GCM encryption of whatever the governance says to protect.
//
// Threads: start-up only, from the thread that builds the participant. Allocates; throws.
#pragma once

#include <memory>
#include <string>
#include <string_view>

#include "config/config.hpp"
#include "io/dds/participant.hpp"

namespace hvac_twin::dds {

// The file a DdsSecurityConfig path names: "${CREDENTIALS_DIRECTORY}/<name>" is resolved against
// `credentials_directory` (the environment variable systemd sets with LoadCredential=; nullptr
// when unset); any other path is returned as is. Throws std::runtime_error naming `field` (e.g.
// "dds.security.private_key") if the variable is needed but unset or empty, or if the resolved
// path contains characters Cyclone's XML would misread (control characters, < > & $ \).
std::string resolve_security_path(std::string_view field, std::string_view path,
                                  const char* credentials_directory);

// The Cyclone XML fragment <Security>...</Security> for `security`, every path resolved with the
// process's CREDENTIALS_DIRECTORY. Checks that each file is a readable, non-empty regular file
// and throws std::runtime_error naming the field, the path and the reason otherwise ("cannot read
// dds.security.governance '/etc/x.p7s': No such file or directory").
std::string make_security_xml(const config::DdsSecurityConfig& security);

// The participant for `config`: with DDS Security when config.security is set. While Cyclone
// builds it, Cyclone's error messages are collected (and still written to stderr as usual); when
// it refuses, the std::runtime_error thrown carries them, e.g. "... refused by DDS Security:
// Permissions validity period expired for CN=...". When the process may not open AF_NETLINK
// sockets (a sandbox), the error says that instead. Other failures as Participant's constructor.
std::unique_ptr<Participant> make_participant(const config::DdsConfig& config);

}  // namespace hvac_twin::dds
