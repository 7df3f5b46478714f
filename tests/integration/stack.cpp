// The out-of-line half of Stack (stack.hpp): the parts that instantiate std::regex and
// nlohmann::json's parser and serialiser, compiled once rather than in every test file that
// includes the header (each cost ~9 s of compile time per file under the sanitizers).
#include "tests/integration/stack.hpp"

#include <chrono>
#include <csignal>
#include <regex>
#include <thread>

namespace hvac_twin::test {

std::optional<std::vector<std::string>> regex_find(const std::string& text,
                                                   const std::string& pattern) {
  std::smatch m;
  if (!std::regex_search(text, m, std::regex(pattern))) return std::nullopt;
  std::vector<std::string> groups;
  for (const auto& g : m)
    groups.push_back(g.str());
  return groups;
}

int Stack::start_sim(int port) {
  write_config(port == 0 ? 1 : port, false);  // the simulator reads the same file
  std::vector<std::string> args{
      "--config",    path("config.json"),
      "--port",      std::to_string(port),
      "--seed",      std::to_string(o_.seed),
      "--step",      std::to_string(o_.sim_step_s),
      "--truth-csv", path("truth-" + std::to_string(++sim_starts_) + ".csv"),
      "--quiet"};
  args.insert(args.end(), o_.sim_args.begin(), o_.sim_args.end());
  sim_ = std::make_unique<Process>(HVAC_TWIN_SIM_EXE, args, path("sim.out"), path("sim.err"));
  const std::regex line(R"(127\.0\.0\.1:(\d+) unit id)");
  std::smatch m;
  std::string out;
  const bool up = eventually(
      [&] {
        out = sim_->out();
        return std::regex_search(out, m, line) && out.find("\n", m.position()) != out.npos;
      },
      std::chrono::seconds(10));
  if (!up) throw std::runtime_error("simulator did not start: " + sim_->err());
  port_ = std::stoi(m[1].str());
  return port_;
}

const char* daemon_exe(const std::vector<std::string>& args) {
  const bool faults = std::any_of(args.begin(), args.end(),
                                  [](const std::string& a) { return a.rfind("--fault-", 0) == 0; });
  return faults ? HVAC_TWIND_FAULTS_EXE : HVAC_TWIND_EXE;
}

void Stack::start_daemon_under(const std::vector<std::string>& wrapper,
                               const std::vector<std::string>& extra_args,
                               const std::vector<std::string>& env) {
  write_config(port_, true);
  std::vector<std::string> args;
  if (!wrapper.empty()) {
    args.assign(wrapper.begin() + 1, wrapper.end());
    args.push_back(daemon_exe(extra_args));
  }
  args.insert(args.end(), {"--config", path("config.json")});
  args.insert(args.end(), extra_args.begin(), extra_args.end());
  daemon_ = std::make_unique<Process>(wrapper.empty() ? daemon_exe(extra_args) : wrapper[0], args,
                                      path("daemon.out"), path("daemon.err"), env);
}

void Stack::start_echo(double duration_s, const std::vector<std::string>& extra_args) {
  std::vector<std::string> args{"--domain",   std::to_string(o_.domain_id), "--format", "json",
                                "--duration", std::to_string(duration_s)};
  args.insert(args.end(), extra_args.begin(), extra_args.end());
  echo_ = std::make_unique<Process>(HVAC_TWIN_ECHO_EXE, args, path("echo.jsonl"), path("echo.err"));
}

std::optional<int> Stack::run_for(double model_h, const std::vector<std::string>& echo_args,
                                  std::chrono::milliseconds stop_timeout) {
  const double wall_s = model_h * 3600.0 / o_.time_scale;
  start_sim();
  start_daemon();
  start_echo(wall_s + 10.0, echo_args);
  std::this_thread::sleep_for(std::chrono::duration<double>(wall_s));
  daemon_->signal(SIGTERM);
  const auto rc = daemon_->wait(stop_timeout);
  stop_sim();
  echo_->signal(SIGTERM);
  echo_->wait(std::chrono::seconds(5));
  return rc;
}

std::vector<nlohmann::json> read_json_lines(const std::string& path) {
  std::vector<nlohmann::json> out;
  std::ifstream f(path);
  std::string line;
  while (std::getline(f, line)) {
    if (f.eof()) break;  // no newline yet: still being written
    out.push_back(nlohmann::json::parse(line));
  }
  return out;
}

void Stack::write_config(int port, bool for_daemon) const {
  std::ifstream in(std::string(HVAC_TWIN_SOURCE_DIR) + "/" + o_.base_config);
  nlohmann::json c = nlohmann::json::parse(in);
  auto& unit = c["units"][0];
  unit["modbus"]["port"] = port;
  unit["modbus"]["poll_period_s"] = o_.poll_period_s;
  unit["modbus"]["response_timeout_s"] = o_.poll_period_s * 0.4;
  unit["modbus"]["byte_timeout_s"] = o_.poll_period_s * 0.2;
  unit["estimator"]["period_s"] = o_.period_s;
  unit["estimator"]["deadline_s"] = o_.deadline_s;
  c["dds"]["domain_id"] = o_.domain_id;
  c["runtime"]["time_scale"] = o_.time_scale;
  c["state_directory"] = path("state");
  if (o_.customize) o_.customize(c);
  if (for_daemon && o_.daemon_customize) o_.daemon_customize(c);
  std::ofstream(path("config.json")) << c.dump(2);
}

}  // namespace hvac_twin::test
