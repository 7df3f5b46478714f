#include "io/dds/security.hpp"

#include <dds/dds.h>
#include <fcntl.h>
#include <linux/netlink.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <vector>

namespace hvac_twin::dds {
namespace {

constexpr std::string_view kCredentialsPrefix = "${CREDENTIALS_DIRECTORY}/";

// Characters that Cyclone's configuration parser would not take literally inside element text:
// XML markup, and its own $VAR / ${VAR} expansion with backslash escapes.
bool xml_safe(std::string_view s) {
  for (const char c : s) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) return false;
    if (std::string_view("<>&$\\").find(c) != std::string_view::npos) return false;
  }
  return true;
}

// Throws unless `path` is a readable, non-empty regular file.
void check_readable(std::string_view field, const std::string& path) {
  const auto fail = [&](const std::string& why) {
    throw std::runtime_error("cannot read " + std::string(field) + " '" + path + "': " + why);
  };
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    const int err = errno;
    std::string why = std::strerror(err);
    if (err == EACCES)
      why +=
          " (under systemd with DynamicUser=, pass it with LoadCredential= and use "
          "${CREDENTIALS_DIRECTORY}/<name>)";
    fail(why);
  }
  struct stat st {};
  const int rc = ::fstat(fd, &st);
  ::close(fd);
  if (rc != 0) fail(std::strerror(errno));
  if (!S_ISREG(st.st_mode)) fail("not a regular file");
  if (st.st_size == 0) fail("the file is empty");
}

std::string element(std::string_view name, const std::string& path) {
  std::string out = "<";
  out.append(name).append(">file:").append(path).append("</").append(name).append(">");
  return out;
}

// Collects Cyclone's log messages (errors and warnings) while alive, still writing them to
// stderr as Cyclone's default sink does. Cyclone swaps sinks under a lock and calls them from its
// own threads, hence the mutex.
class CycloneLogCapture {
 public:
  CycloneLogCapture() { dds_set_log_sink(&CycloneLogCapture::sink, this); }
  ~CycloneLogCapture() { dds_set_log_sink(nullptr, nullptr); }
  CycloneLogCapture(const CycloneLogCapture&) = delete;
  CycloneLogCapture& operator=(const CycloneLogCapture&) = delete;

  // The captured error messages, joined with "; "; "" if there was none.
  std::string errors() {
    std::lock_guard lock(mutex_);
    std::string out;
    for (const auto& m : errors_) {
      if (!out.empty()) out += "; ";
      out += m;
    }
    return out;
  }

 private:
  static void sink(void* self, const dds_log_data_t* data) {
    std::fwrite(data->message - data->hdrsize, 1, data->hdrsize + data->size + 1, stderr);
    std::fflush(stderr);
    if ((data->priority & (DDS_LC_ERROR | DDS_LC_FATAL)) == 0) return;
    std::string message(data->message, data->size);
    while (!message.empty() && (message.back() == '\n' || message.back() == ' '))
      message.pop_back();
    for (char& c : message)
      if (c == '\n') c = ' ';
    auto* capture = static_cast<CycloneLogCapture*>(self);
    std::lock_guard lock(capture->mutex_);
    capture->errors_.push_back(std::move(message));
  }

  std::mutex mutex_;
  std::vector<std::string> errors_;
};

// A plain-words reading of Cyclone's most common refusals, or "" when there is none.
std::string hint(const std::string& cyclone_errors) {
  if (cyclone_errors.find("PKCS7") != std::string::npos)
    return "a governance or permissions document does not verify against permissions_ca "
           "(changed after signing, or signed by another CA). ";
  if (cyclone_errors.find("validity period expired") != std::string::npos)
    return "the permissions document has expired: issue and sign a new one. ";
  if (cyclone_errors.find("Subject name is invalid") != std::string::npos)
    return "the permissions document grants another subject than identity_certificate's. ";
  if (cyclone_errors.find("not yet valid") != std::string::npos)
    return "the permissions document is not valid yet (check the clock). ";
  return {};
}

// Why Cyclone cannot work in this process when it may not open netlink sockets (a sandbox without
// AF_NETLINK), or "" when it may.
std::string netlink_refused() {
  const int fd = ::socket(AF_NETLINK, SOCK_RAW | SOCK_CLOEXEC, NETLINK_ROUTE);
  if (fd >= 0) {
    ::close(fd);
    return {};
  }
  return std::string("this process may not open AF_NETLINK sockets (") + std::strerror(errno) +
         "), which Cyclone DDS needs to list the network interfaces: allow AF_NETLINK (systemd: "
         "RestrictAddressFamilies=)";
}

// Creates the participant; a failure that a refused AF_NETLINK explains says so.
std::unique_ptr<Participant> create(const config::DdsConfig& config, std::string_view xml) {
  try {
    return std::make_unique<Participant>(config, xml);
  } catch (const std::runtime_error& e) {
    const std::string why = netlink_refused();
    if (why.empty()) throw;
    throw std::runtime_error(std::string(e.what()) + "; " + why);
  }
}

}  // namespace

std::string resolve_security_path(std::string_view field, std::string_view path,
                                  const char* credentials_directory) {
  std::string resolved(path);
  if (path.starts_with(kCredentialsPrefix)) {
    if (credentials_directory == nullptr || credentials_directory[0] == '\0') {
      throw std::runtime_error(
          std::string(field) + " is '" + std::string(path) +
          "' but CREDENTIALS_DIRECTORY is not set: systemd sets it for a unit with "
          "LoadCredential= (see the README); outside systemd use an absolute path");
    }
    resolved = std::string(credentials_directory) + "/" +
               std::string(path.substr(kCredentialsPrefix.size()));
  }
  if (!xml_safe(resolved)) {
    throw std::runtime_error(std::string(field) + " '" + resolved +
                             "' contains a control character or one of < > & $ \\");
  }
  return resolved;
}

std::string make_security_xml(const config::DdsSecurityConfig& security) {
  const char* credentials = std::getenv("CREDENTIALS_DIRECTORY");
  const auto file = [&](std::string_view key, const std::string& path) {
    const std::string field = "dds.security." + std::string(key);
    std::string resolved = resolve_security_path(field, path, credentials);
    check_readable(field, resolved);
    return resolved;
  };
  const std::string identity_ca = file("identity_ca", security.identity_ca);
  const std::string certificate = file("identity_certificate", security.identity_certificate);
  const std::string private_key = file("private_key", security.private_key);
  const std::string permissions_ca = file("permissions_ca", security.permissions_ca);
  const std::string governance = file("governance", security.governance);
  const std::string permissions = file("permissions", security.permissions);

  // The library names are Cyclone's defaults, spelt out; Debian's libddsc finds them in its
  // private directory (libddsc0debian/).
  return "<Security>"
         "<Authentication>"
         "<Library path=\"dds_security_auth\" initFunction=\"init_authentication\" "
         "finalizeFunction=\"finalize_authentication\"/>" +
         element("IdentityCA", identity_ca) + element("IdentityCertificate", certificate) +
         element("PrivateKey", private_key) +
         "</Authentication>"
         "<AccessControl>"
         "<Library path=\"dds_security_ac\" initFunction=\"init_access_control\" "
         "finalizeFunction=\"finalize_access_control\"/>" +
         element("PermissionsCA", permissions_ca) + element("Governance", governance) +
         element("Permissions", permissions) +
         "</AccessControl>"
         "<Cryptographic>"
         "<Library path=\"dds_security_crypto\" initFunction=\"init_crypto\" "
         "finalizeFunction=\"finalize_crypto\"/>"
         "</Cryptographic>"
         "</Security>";
}

std::unique_ptr<Participant> make_participant(const config::DdsConfig& config) {
  if (!config.security) return create(config, {});
  const std::string xml = make_security_xml(*config.security);
  CycloneLogCapture capture;
  try {
    return create(config, xml);
  } catch (const std::runtime_error& e) {
    if (std::string_view(e.what()).find("AF_NETLINK sockets") != std::string_view::npos) throw;
    const std::string cyclone = capture.errors();
    const std::string why =
        cyclone.empty()
            ? "check that identity_certificate is issued by identity_ca and matches private_key, "
              "that governance and permissions are signed by permissions_ca, and that the "
              "permissions grant this certificate's subject this domain, within their validity"
            : hint(cyclone) + "Cyclone DDS: " + cyclone;
    throw std::runtime_error(std::string(e.what()) + "; refused by DDS Security: " + why);
  }
}

}  // namespace hvac_twin::dds
