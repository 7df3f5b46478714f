// hvac-twin-test-sandbox: runs a program under the seccomp restrictions that systemd applies for
// RestrictAddressFamilies= and SystemCallFilter=, so a test can show that hvac-twind works inside
// its unit's sandbox without a running systemd.
//
//   hvac-twin-test-sandbox [--address-families AF_UNIX,AF_INET,...] [--syscalls FILE]
//                          [--setenv NAME=VALUE]... -- PROGRAM [ARGS...]
//
// --address-families: socket() with any other family fails with EAFNOSUPPORT, as systemd does
//   (socketpair() and inherited sockets are not affected, as with systemd).
// --syscalls FILE: only the system calls named in FILE (one per line) are allowed; any other
//   kills the process with SIGSYS, so a test notices every call the unit would refuse (the unit
//   itself answers them with EPERM). Names unknown on this architecture are skipped.
// --setenv: set (replace) an environment variable of PROGRAM.
// Sets no_new_privs (NoNewPrivileges=yes), checks that the filter bites (socket(AF_PACKET)
// must fail unless allowed), then execs PROGRAM. Exit 125 on a usage or set-up error.
#include <seccomp.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <set>
#include <string>
#include <string_view>
#include <vector>

namespace {

constexpr int kSetupFailed = 125;

// SCMP_A0 without its compound literal (a C99 feature that clang flags in C++).
scmp_arg_cmp first_argument(scmp_compare op, int value) {
  scmp_arg_cmp cmp{};
  cmp.arg = 0;
  cmp.op = op;
  cmp.datum_a = static_cast<scmp_datum_t>(value);
  return cmp;
}

struct Family {
  const char* name;
  int value;
};
constexpr Family kFamilies[] = {
    {"AF_UNIX", AF_UNIX},     {"AF_INET", AF_INET},
    {"AF_INET6", AF_INET6},   {"AF_NETLINK", AF_NETLINK},
    {"AF_PACKET", AF_PACKET}, {"AF_BLUETOOTH", AF_BLUETOOTH},
    {"AF_ALG", AF_ALG},       {"AF_VSOCK", AF_VSOCK},
    {"AF_CAN", AF_CAN},       {"AF_APPLETALK", AF_APPLETALK},
    {"AF_X25", AF_X25},       {"AF_KEY", AF_KEY},
};

int fail(const std::string& message) {
  std::fprintf(stderr, "hvac-twin-test-sandbox: %s\n", message.c_str());
  return kSetupFailed;
}

bool parse_families(std::string_view list, std::set<int>& out, std::string& error) {
  while (!list.empty()) {
    const std::size_t comma = list.find(',');
    const std::string_view name = list.substr(0, comma);
    bool found = false;
    for (const auto& f : kFamilies)
      if (name == f.name) {
        out.insert(f.value);
        found = true;
      }
    if (!found) {
      error = "unknown address family '" + std::string(name) + "'";
      return false;
    }
    list = comma == std::string_view::npos ? std::string_view{} : list.substr(comma + 1);
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  bool restrict_families = false;
  std::set<int> families;
  std::string syscalls_file;
  int i = 1;
  for (; i < argc; ++i) {
    const std::string_view arg = argv[i];
    if (arg == "--") {
      ++i;
      break;
    }
    if (i + 1 >= argc) return fail("option " + std::string(arg) + " needs a value");
    if (arg == "--address-families") {
      std::string error;
      if (!parse_families(argv[++i], families, error)) return fail(error);
      restrict_families = true;
    } else if (arg == "--syscalls") {
      syscalls_file = argv[++i];
    } else if (arg == "--setenv") {
      const std::string assignment = argv[++i];
      const std::size_t eq = assignment.find('=');
      if (eq == 0 || eq == std::string::npos) return fail("--setenv needs NAME=VALUE");
      if (setenv(assignment.substr(0, eq).c_str(), assignment.c_str() + eq + 1, 1) != 0)
        return fail("setenv failed");
    } else {
      return fail("unknown option " + std::string(arg));
    }
  }
  if (i >= argc) return fail("no program given (after --)");

  if (prctl(PR_SET_NO_NEW_PRIVS, 1, 0, 0, 0) != 0) return fail("PR_SET_NO_NEW_PRIVS failed");
  const bool allow_list = !syscalls_file.empty();
  scmp_filter_ctx ctx = seccomp_init(allow_list ? SCMP_ACT_KILL_PROCESS : SCMP_ACT_ALLOW);
  if (ctx == nullptr) return fail("seccomp_init failed");

  const int socket_nr = seccomp_syscall_resolve_name("socket");
  if (allow_list) {
    std::ifstream in(syscalls_file);
    if (!in) return fail("cannot read " + syscalls_file);
    std::string name;
    int allowed = 0;
    while (std::getline(in, name)) {
      if (name.empty() || name[0] == '#') continue;
      const int nr = seccomp_syscall_resolve_name(name.c_str());
      if (nr == __NR_SCMP_ERROR) continue;                 // not a system call on this architecture
      if (nr == socket_nr && restrict_families) continue;  // conditional rules below
      const int rc = seccomp_rule_add(ctx, SCMP_ACT_ALLOW, nr, 0);
      if (rc != 0) return fail("seccomp_rule_add(" + name + "): " + std::strerror(-rc));
      ++allowed;
    }
    if (allowed < 50) return fail("implausibly short system call list in " + syscalls_file);
  }
  if (restrict_families) {
    // Every family below AF_MAX that is not allowed fails with EAFNOSUPPORT; so does any larger
    // value. With an allow list, the allowed families are allowed explicitly.
    for (int af = 0; af < AF_MAX; ++af) {
      const bool allowed = families.count(af) != 0;
      if (allowed && !allow_list) continue;
      const uint32_t action = allowed ? SCMP_ACT_ALLOW : SCMP_ACT_ERRNO(EAFNOSUPPORT);
      const int rc = seccomp_rule_add(ctx, action, socket_nr, 1, first_argument(SCMP_CMP_EQ, af));
      if (rc != 0) return fail(std::string("seccomp_rule_add(socket): ") + std::strerror(-rc));
    }
    const int rc = seccomp_rule_add(ctx, SCMP_ACT_ERRNO(EAFNOSUPPORT), socket_nr, 1,
                                    first_argument(SCMP_CMP_GE, AF_MAX));
    if (rc != 0) return fail(std::string("seccomp_rule_add(socket): ") + std::strerror(-rc));
  }
  const int rc = seccomp_load(ctx);
  seccomp_release(ctx);
  if (rc != 0) return fail(std::string("seccomp_load: ") + std::strerror(-rc));

  // The filter bites: a packet socket is refused unless allowed.
  if (restrict_families && families.count(AF_PACKET) == 0) {
    const int fd = socket(AF_PACKET, SOCK_RAW, 0);
    if (fd >= 0 || errno != EAFNOSUPPORT)
      return fail("socket(AF_PACKET) was not refused with EAFNOSUPPORT");
  }
  execv(argv[i], argv + i);
  return fail(std::string("cannot exec ") + argv[i] + ": " + std::strerror(errno));
}
