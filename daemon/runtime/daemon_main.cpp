// hvac-twind's command line and life (daemon_main.hpp).
#include "daemon/runtime/daemon_main.hpp"

#include <signal.h>

#include <algorithm>
#include <csignal>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <exception>
#include <string>
#include <string_view>

#include "config/load.hpp"
#include "daemon/runtime/daemon.hpp"
#include "daemon/runtime/logging.hpp"
#include "daemon/runtime/unit_model.hpp"

namespace {

constexpr const char* kDefaultConfig = "/etc/hvac-twin/hvac-twin.json";

void usage(std::FILE* to) {
  std::fprintf(to,
               "usage: hvac-twind [--config FILE] [--log-level LEVEL]\n"
               "       hvac-twind --check-config FILE\n"
               "\n"
               "Real-time constrained-EKF digital twin of HVAC units: reads sensor points over\n"
               "Modbus TCP, estimates what is not measured, publishes it over DDS.\n"
               "\n"
               "  --config FILE        configuration (default %s)\n"
               "  --check-config FILE  validate FILE, print its errors, exit 0 or 78\n"
               "  --log-level LEVEL    trace|debug|info|warn|error (overrides the file)\n"
               "  --version            print the version\n"
               "\n"
               "Exit status: 0 after SIGTERM/SIGINT, 78 invalid configuration, 70 a hung cycle,\n"
               "1 any other start-up failure.\n",
               kDefaultConfig);
}

hvac_twin::config::LoadResult load(const std::string& path) {
  return hvac_twin::config::load_config_file(path, hvac_twin::runtime::model_catalog());
}

// Prints the first config::kMaxShownErrors errors of `result`; returns how many it left out.
std::size_t print_errors(const hvac_twin::config::LoadResult& result, const std::string& path) {
  std::fputs(hvac_twin::config::format_errors(result.errors, path).c_str(), stderr);
  return result.error_count() - std::min(result.errors.size(), hvac_twin::config::kMaxShownErrors);
}

const char* signal_name(int sig) {
  return sig == SIGTERM ? "SIGTERM" : "SIGINT";
}

// The signals hvac-twind waits for (sigwait in main), blocked for the whole process.
sigset_t stop_signals() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGINT);
  return set;
}

}  // namespace

namespace hvac_twin::runtime {

int daemon_main(int argc, char** argv, CycleHooks* hooks) {
  // First thing: block the signals the daemon waits for, so that one arriving while the
  // configuration loads or the units start stays pending and ends in a clean shut-down (exit 0,
  // logged) instead of the default action (status 143, nothing logged). Every thread inherits
  // this mask; the main thread alone takes the signals, with sigwait.
  const sigset_t signals = stop_signals();
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  // A log pipe whose reader died (the demo's `sed` on Ctrl-C, a journal restarting) must not kill
  // the daemon by SIGPIPE in the middle of its shut-down (a checkpoint being written, exit 0):
  // writes to it fail with EPIPE instead, which the loggers ignore.
  std::signal(SIGPIPE, SIG_IGN);

  std::string config_path = kDefaultConfig;
  std::string log_level;
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--help" || arg == "-h") {
      usage(stdout);
      return 0;
    } else if (arg == "--version") {
      std::printf("hvac-twind %s\n", HVAC_TWIN_VERSION);
      return 0;
    } else if (arg == "--check-config" && has_value) {
      // A one-shot command: Ctrl-C or SIGTERM ends it at once, as it would any other tool.
      pthread_sigmask(SIG_UNBLOCK, &signals, nullptr);
      const std::string path = argv[++i];
      const auto result = load(path);
      if (!result.errors.empty()) {
        const std::size_t hidden = print_errors(result, path);
        std::fprintf(stderr, "%s: %zu error(s)", path.c_str(), result.error_count());
        if (hidden > 0) std::fprintf(stderr, ", %zu more not shown", hidden);
        std::fputc('\n', stderr);
        return hvac_twin::config::kExitConfigError;
      }
      std::printf("%s: valid (%zu unit(s))\n", path.c_str(), result.config->units.size());
      return 0;
    } else if (arg == "--config" && has_value) {
      config_path = argv[++i];
    } else if (arg == "--log-level" && has_value) {
      log_level = argv[++i];
    } else {
      std::fprintf(stderr, "hvac-twind: unknown or incomplete option \"%s\"\n\n", argv[i]);
      usage(stderr);
      return 2;
    }
  }

  auto result = load(config_path);
  if (!result.errors.empty()) {
    const std::size_t hidden = print_errors(result, config_path);
    std::fprintf(stderr, "hvac-twind: invalid configuration, ");
    if (hidden > 0) std::fprintf(stderr, "%zu more error(s) not shown; ", hidden);
    std::fprintf(stderr, "not starting\n");
    return hvac_twin::config::kExitConfigError;
  }
  hvac_twin::config::Config config = std::move(*result.config);
  if (!log_level.empty()) config.runtime.log_level = log_level;

  std::shared_ptr<spdlog::logger> log;
  try {
    log = hvac_twin::runtime::make_logger(config.runtime.log_level);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hvac-twind: %s\n", e.what());
    return hvac_twin::config::kExitConfigError;
  }

  log->info("hvac-twind {} starting with {}", HVAC_TWIN_VERSION, config_path);
  // Asked to stop while the configuration loaded: nothing was started, so nothing to stop.
  const timespec no_wait{};
  if (const int early = sigtimedwait(&signals, nullptr, &no_wait); early > 0) {
    log->info("{} received during start-up, exiting before the units start", signal_name(early));
    return 0;
  }
  Daemon daemon(std::move(config), log, hooks);
  try {
    daemon.start();
  } catch (const UnitModelError& e) {
    // Valid on paper, refused by the model file itself (an FMU's binary): a configuration error.
    log->critical("start-up failed: {}: {}: {}", config_path, e.pointer(), e.what());
    return hvac_twin::config::kExitConfigError;
  } catch (const std::exception& e) {
    log->critical("start-up failed: {}", e.what());
    return 1;
  }
  int sig = 0;
  sigwait(&signals, &sig);
  log->info("{} received, shutting down", signal_name(sig));
  daemon.stop();
  return 0;
}

}  // namespace hvac_twin::runtime
