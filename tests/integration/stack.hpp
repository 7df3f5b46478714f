// The whole product on loopback for integration tests: hvac-twin-sim serving the plant over
// Modbus TCP, hvac-twind estimating, hvac-twin-echo recording every DDS sample as JSON lines.
// Each stack gets its own directory, DDS domain and Modbus port, so tests run in parallel.
#pragma once

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "tests/integration/process.hpp"
#include "tests/support/scratch_dir.hpp"

namespace hvac_twin::test {

struct StackOptions {
  int domain_id = 50;
  double time_scale = 1200.0;  // model seconds per wall second
  double period_s = 120.0;     // model seconds per estimator cycle
  double deadline_s = 0.05;    // wall
  double poll_period_s = 0.025;
  double sim_step_s = 10.0;  // model seconds per truth step
  std::uint64_t seed = 1;
  std::string base_config = "config/demo.json";    // relative to the source tree
  std::function<void(nlohmann::json&)> customize;  // last edit of the configuration
  // An edit of the daemon's configuration only, after `customize` (the simulator's plant stays
  // the configuration's built-in model, e.g. when the daemon runs it as an FMU).
  std::function<void(nlohmann::json&)> daemon_customize;
  std::vector<std::string> sim_args;  // more simulator options (e.g. --leak)
};

// For the tests of topics and the daemon's life on the heat pump (not of its accuracy): the
// cheapest model the demo configuration can run, 4 cells with alpha constant per coil and only
// the outdoor-coil fouling augmented, so that a cycle stays inside its deadline under the
// sanitizers too. (With the default closure at 12 cells and at 6, and with the constant one at
// 10, cycles under ASan took 0.5-1.5 s.)
inline void cheapest_heat_pump(nlohmann::json& c) {
  auto& p = c["units"][0]["model"]["parameters"];
  for (auto it = p.begin(); it != p.end();)
    it = it.key().rfind("augment_", 0) == 0 ? p.erase(it) : std::next(it);
  p["augment_fouling"] = 1;
  p["cells"] = 4;
  p["two_phase_htc"] = 0;
}

// The daemon to run with these options: hvac-twind, or hvac-twind-faults when one of them is a
// fault-injection hook (--fault-*, tests/support/fault_daemon_main.cpp).
const char* daemon_exe(const std::vector<std::string>& args);

// Every complete JSON line of the file (a partial last line, still being written, is skipped).
std::vector<nlohmann::json> read_json_lines(const std::string& path);

// The first match of ECMAScript regex `pattern` in `text`: the whole match, then each capture
// group; nullopt when there is none. (Here, not <regex> in every test: see stack.cpp.)
std::optional<std::vector<std::string>> regex_find(const std::string& text,
                                                   const std::string& pattern);

// The zone daemon for tests of its life and its wire: 60x real time, a 30 s period (0.5 s wall).
inline StackOptions zone_stack_options(int domain) {
  StackOptions o;
  o.domain_id = domain;
  o.time_scale = 60.0;
  o.period_s = 30.0;
  o.poll_period_s = 0.1;
  return o;
}

// The heat-pump daemon for tests of its topics and its life: the cheapest model
// (cheapest_heat_pump), a shorter start than the demo's, 10x real time with a 5 s period (0.5 s
// wall) and a 0.45 s deadline.
inline StackOptions heat_pump_stack_options(int domain) {
  StackOptions o;
  o.domain_id = domain;
  o.time_scale = 10.0;
  o.period_s = 5.0;
  o.deadline_s = 0.45;
  o.poll_period_s = 0.1;
  o.sim_step_s = 1.0;
  o.base_config = "config/demo-heat-pump.json";
  o.customize = [](nlohmann::json& c) {
    cheapest_heat_pump(c);
    c["units"][0]["estimator"]["settle_s"] = 300.0;
  };
  return o;
}

class Stack {
 public:
  Stack(const std::string& name, StackOptions o) : dir_("it-" + name), o_(o) {}
  ~Stack() {
    echo_.reset();
    daemon_.reset();
    sim_.reset();
  }

  std::string path(const std::string& file) const { return dir_ / file; }

  // Starts the simulator (port 0: ephemeral, learnt from its first line) and returns its port.
  int start_sim(int port = 0);
  // The simulator's extra options from its next start_sim() on (e.g. another --noise-scale).
  void set_sim_args(std::vector<std::string> args) { o_.sim_args = std::move(args); }
  void stop_sim() {
    sim_->signal(SIGTERM);
    sim_->wait(std::chrono::seconds(10));
  }

  void start_daemon(const std::vector<std::string>& extra_args = {},
                    const std::vector<std::string>& env = {}) {
    start_daemon_under({}, extra_args, env);
  }
  // The daemon as the last argument of `wrapper` (e.g. strace and its options; wrapper[0] an
  // absolute path), or directly when `wrapper` is empty.
  void start_daemon_under(const std::vector<std::string>& wrapper,
                          const std::vector<std::string>& extra_args = {},
                          const std::vector<std::string>& env = {});

  void start_echo(double duration_s, const std::vector<std::string>& extra_args = {});

  // The whole run of most tests: the simulator, the daemon and the echo (with `echo_args`) for
  // `model_h` model hours, then SIGTERM to the daemon, waited for up to `stop_timeout`, and the
  // simulator and the echo stopped. The daemon's exit status (nullopt: it did not exit).
  std::optional<int> run_for(double model_h, const std::vector<std::string>& echo_args = {},
                             std::chrono::milliseconds stop_timeout = std::chrono::seconds(10));

  Process& sim() { return *sim_; }
  Process& daemon() { return *daemon_; }
  Process& echo() { return *echo_; }
  int port() const { return port_; }
  const StackOptions& options() const { return o_; }

  // Every JSON line the echo has written so far (a partial last line is skipped).
  std::vector<nlohmann::json> samples() const { return read_json_lines(path("echo.jsonl")); }

  // The demo configuration, made fast and private to this stack (for the simulator: without
  // daemon_customize).
  void write_config(int port, bool for_daemon = true) const;

 private:
  ScratchDir dir_;  // first: removed after the processes writing into it are gone
  StackOptions o_;
  int port_ = 0;
  int sim_starts_ = 0;
  std::unique_ptr<Process> sim_, daemon_, echo_;
};

}  // namespace hvac_twin::test
