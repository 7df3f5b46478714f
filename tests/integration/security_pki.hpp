// Throw-away DDS Security material for tests, made with the openssl command line at test time:
// an identity CA, a permissions CA and an unrelated "other" CA; identities for the daemon, a
// permitted subscriber and a rogue (issued by the other CA, with the permitted subscriber's
// subject); the governance and permissions documents made from the templates the project ships
// (io/dds/security/), signed by the permissions CA; and broken variants (tampered governance,
// expired permissions). EC P-256 keys, so generation takes well under a second.
#pragma once

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>

#include <chrono>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "config/config.hpp"

extern char** environ;

namespace hvac_twin::test {

class TestPki {
 public:
  static constexpr const char* kDaemonSubject = "CN=hvac-twind,O=hvac-twin-test";
  static constexpr const char* kSubscriberSubject = "CN=dashboard,O=hvac-twin-test";

  // Generates everything into `dir` (created) for DDS domain `domain` and topic prefix `prefix`.
  TestPki(std::filesystem::path dir, int domain, const std::string& prefix) : dir_(std::move(dir)) {
    std::filesystem::create_directories(dir_);
    make_ca("identity_ca", "hvac-twin test identity CA");
    make_ca("permissions_ca", "hvac-twin test permissions CA");
    make_ca("other_ca", "some other CA");
    make_identity("daemon", "identity_ca", kDaemonSubject);
    make_identity("subscriber", "identity_ca", kSubscriberSubject);
    make_identity("rogue", "other_ca", kSubscriberSubject);

    sign(read(template_path("governance.xml")), "governance");
    const auto now = std::chrono::system_clock::now();
    const auto day = std::chrono::hours(24);
    write_permissions("daemon", "publisher", kDaemonSubject, now - day, now + day, domain, prefix);
    write_permissions("subscriber", "subscriber", kSubscriberSubject, now - day, now + day, domain,
                      prefix);
    write_permissions("daemon_expired", "publisher", kDaemonSubject, now - 30 * day, now - day,
                      domain, prefix);
    // Signed content changed after signing: unauthenticated participants let in.
    std::string governance = read(path("governance.p7s"));
    const std::string honest = "<allow_unauthenticated_participants>false";
    const auto at = governance.find(honest);
    if (at == std::string::npos) throw std::runtime_error("governance template changed");
    governance.replace(at, honest.size(), "<allow_unauthenticated_participants>true");
    std::ofstream(path("governance_tampered.p7s")) << governance;
  }

  std::string path(const std::string& file) const { return (dir_ / file).string(); }
  const std::filesystem::path& dir() const { return dir_; }

  // The security configuration of `identity` ("daemon", "subscriber", "rogue"): its certificate
  // and key, trusting `identity_ca`, with the governance and `permissions` documents.
  config::DdsSecurityConfig security(const std::string& identity,
                                     const std::string& identity_ca = "identity_ca",
                                     const std::string& permissions = "") const {
    config::DdsSecurityConfig s;
    s.identity_ca = path(identity_ca + ".pem");
    s.identity_certificate = path(identity + ".pem");
    s.private_key = path(identity + ".key");
    s.permissions_ca = path("permissions_ca.pem");
    s.governance = path("governance.p7s");
    s.permissions = path((permissions.empty() ? identity : permissions) + "_permissions.p7s");
    return s;
  }

  // hvac-twin-echo options for `s`.
  static std::vector<std::string> echo_args(const config::DdsSecurityConfig& s) {
    return {"--identity-ca", s.identity_ca, "--identity-certificate", s.identity_certificate,
            "--private-key", s.private_key, "--permissions-ca",       s.permissions_ca,
            "--governance",  s.governance,  "--permissions",          s.permissions};
  }

  static std::string template_path(const std::string& file) {
    return std::string(HVAC_TWIN_SOURCE_DIR) + "/io/dds/security/" + file;
  }

 private:
  static std::string read(const std::string& file) {
    std::ifstream in(file);
    if (!in) throw std::runtime_error("cannot read " + file);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

  static std::string utc(std::chrono::system_clock::time_point t) {
    const std::time_t seconds = std::chrono::system_clock::to_time_t(t);
    std::tm tm{};
    gmtime_r(&seconds, &tm);
    char buf[32];
    std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
    return buf;
  }

  static void replace_all(std::string& s, const std::string& from, const std::string& to) {
    for (std::size_t at = s.find(from); at != std::string::npos; at = s.find(from, at + to.size()))
      s.replace(at, from.size(), to);
  }

  // Runs openssl with `args`; throws with its stderr if it fails.
  void openssl(std::vector<std::string> args) const {
    args.insert(args.begin(), "openssl");
    std::vector<char*> argv;
    for (auto& a : args)
      argv.push_back(a.data());
    argv.push_back(nullptr);
    const std::string err = path("openssl.err");
    posix_spawn_file_actions_t fa;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&fa, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    pid_t pid = 0;
    const int rc = posix_spawnp(&pid, "openssl", &fa, nullptr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    if (rc != 0) throw std::runtime_error("cannot run openssl (is it installed?)");
    int status = 0;
    ::waitpid(pid, &status, 0);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
      throw std::runtime_error("openssl " + args[1] + " failed: " + read(err));
  }

  void make_ca(const std::string& name, const std::string& cn) const {
    openssl({"req", "-x509", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
             "-keyout", path(name + ".key"), "-out", path(name + ".pem"), "-days", "2", "-subj",
             "/CN=" + cn});
  }

  void make_identity(const std::string& name, const std::string& ca,
                     const std::string& subject) const {
    std::string slash_subject = "/" + subject;  // CN=a,O=b -> /CN=a/O=b
    replace_all(slash_subject, ",", "/");
    openssl({"req", "-new", "-newkey", "ec", "-pkeyopt", "ec_paramgen_curve:prime256v1", "-nodes",
             "-keyout", path(name + ".key"), "-out", path(name + ".csr"), "-subj", slash_subject});
    openssl({"x509", "-req", "-in", path(name + ".csr"), "-CA", path(ca + ".pem"), "-CAkey",
             path(ca + ".key"), "-set_serial", std::to_string(++serial_), "-days", "2", "-out",
             path(name + ".pem")});
  }

  void sign(const std::string& document, const std::string& name) const {
    std::ofstream(path(name + ".xml")) << document;
    openssl({"smime", "-sign", "-text", "-in", path(name + ".xml"), "-out", path(name + ".p7s"),
             "-signer", path("permissions_ca.pem"), "-inkey", path("permissions_ca.key")});
  }

  void write_permissions(const std::string& name, const std::string& role,
                         const std::string& subject, std::chrono::system_clock::time_point from,
                         std::chrono::system_clock::time_point to, int domain,
                         const std::string& prefix) const {
    std::string doc = read(template_path("permissions-" + role + ".xml"));
    replace_all(doc, "{{SUBJECT}}", subject);
    replace_all(doc, "{{NOT_BEFORE}}", utc(from));
    replace_all(doc, "{{NOT_AFTER}}", utc(to));
    replace_all(doc, "{{DOMAIN}}", std::to_string(domain));
    replace_all(doc, "{{TOPIC_PREFIX}}", prefix);
    sign(doc, name + "_permissions");
  }

  std::filesystem::path dir_;
  mutable int serial_ = 0;
};

}  // namespace hvac_twin::test
