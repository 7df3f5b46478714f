// hvac-twind and hvac-twin-echo as processes against an in-process Modbus fault server
// (tests/fault): the demo configuration pointed at the server's port, with fast polling and a
// back-off short enough that one fault costs one poll. Each rig has its own directory and DDS
// domain (80..99), so tests run in parallel.
#pragma once

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tests/fault/fault_server.hpp"
#include "tests/integration/process.hpp"
#include "tests/integration/stack.hpp"

namespace hvac_twin::test {

struct FaultRigOptions {
  int domain_id = 80;
  double time_scale = 600.0;  // model seconds per wall second
  double period_s = 60.0;     // model seconds per cycle: 0.1 s wall
  double deadline_s = 0.05;   // wall
  double poll_period_s = 0.2;
  double response_timeout_s = 0.08;
  double byte_timeout_s = 0.04;
  double backoff_initial_s = 0.04;  // + jitter + a timed-out read stays below one poll period
  double backoff_max_s = 2.0;
  std::function<void(nlohmann::json&)> customize;  // last edit of the configuration
};

class FaultRig {
 public:
  FaultRig(const std::string& name, int port, FaultRigOptions o)
      : dir_("fault-" + name), o_(std::move(o)) {
    write_config(port);
  }
  ~FaultRig() {
    echo_.reset();
    daemon_.reset();
  }

  std::string path(const std::string& file) const { return dir_ / file; }
  const FaultRigOptions& options() const { return o_; }
  double wall_period_s() const { return o_.period_s / o_.time_scale; }

  void start_daemon(const std::vector<std::string>& extra_args = {}) {
    std::vector<std::string> args{"--config", path("config.json")};
    args.insert(args.end(), extra_args.begin(), extra_args.end());
    daemon_ =
        std::make_unique<Process>(daemon_exe(args), args, path("daemon.out"), path("daemon.err"));
  }
  void start_echo(double duration_s) {
    echo_ = std::make_unique<Process>(
        HVAC_TWIN_ECHO_EXE,
        std::vector<std::string>{"--domain", std::to_string(o_.domain_id), "--format", "json",
                                 "--duration", std::to_string(duration_s)},
        path("echo.jsonl"), path("echo.err"));
  }
  Process& daemon() { return *daemon_; }

  // Every complete JSON line the echo has written so far.
  std::vector<nlohmann::json> samples() const { return read_json_lines(path("echo.jsonl")); }

 private:
  void write_config(int port) const {
    std::ifstream in(std::string(HVAC_TWIN_SOURCE_DIR) + "/config/demo.json");
    nlohmann::json c = nlohmann::json::parse(in);
    auto& m = c["units"][0]["modbus"];
    m["port"] = port;
    m["poll_period_s"] = o_.poll_period_s;
    m["response_timeout_s"] = o_.response_timeout_s;
    m["byte_timeout_s"] = o_.byte_timeout_s;
    m["backoff_initial_s"] = o_.backoff_initial_s;
    m["backoff_max_s"] = o_.backoff_max_s;
    auto& e = c["units"][0]["estimator"];
    e["period_s"] = o_.period_s;
    e["deadline_s"] = o_.deadline_s;
    c["dds"]["domain_id"] = o_.domain_id;
    c["runtime"]["time_scale"] = o_.time_scale;
    c["state_directory"] = path("state");
    if (o_.customize) o_.customize(c);
    std::ofstream(path("config.json")) << c.dump(2);
  }

  ScratchDir dir_;  // first: removed after the processes writing into it are gone
  FaultRigOptions o_;
  std::unique_ptr<Process> daemon_, echo_;
};

// The points of config/demo.json (zone_temp input 0 int16 x0.01 degC, outdoor_temp input 1
// int16 x0.1 degC, hp_heat input 2 float32 CDAB kW), as the fault server encodes them.
inline config::PointConfig demo_point(const std::string& name) {
  config::PointConfig p;
  p.name = name;
  p.kind = config::RegisterKind::kInput;
  p.range_min = -1e9;
  p.range_max = 1e9;
  if (name == "zone_temp") {
    p.address = 0;
    p.type = config::ValueType::kInt16;
    p.scale = 0.01;
  } else if (name == "outdoor_temp") {
    p.address = 1;
    p.type = config::ValueType::kInt16;
    p.scale = 0.1;
  } else {
    p.address = 2;
    p.type = config::ValueType::kFloat32;
    p.word_order = config::WordOrder::kCDAB;
  }
  return p;
}

// True when every number anywhere in `j` is finite and no value is null (how nlohmann::json
// writes NaN and infinities).
inline bool all_finite(const nlohmann::json& j) {
  if (j.is_null()) return false;
  if (j.is_number_float()) return std::isfinite(j.get<double>());
  if (j.is_structured()) {
    for (const auto& v : j)
      if (!all_finite(v)) return false;
  }
  return true;
}

// The newest sample of `topic` whose `key` field equals `name` (any sample when key is empty),
// stamped after `after_ns`; a null json if none.
inline nlohmann::json newest(const std::vector<nlohmann::json>& samples, const std::string& topic,
                             const std::string& key, const std::string& name,
                             std::int64_t after_ns) {
  nlohmann::json found;
  for (const auto& s : samples)
    if (s["topic"] == topic && (key.empty() || s[key] == name) &&
        s["timestamp_ns"].get<std::int64_t>() > after_ns)
      found = s;
  return found;
}

}  // namespace hvac_twin::test
