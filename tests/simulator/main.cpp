// hvac-twin-sim: a truth simulation of one configured unit, served over Modbus TCP on 127.0.0.1.
//
// It reads the daemon's own configuration, so each point is served at the address, type, word
// order, scale and offset the daemon decodes. SIGUSR1 takes the Modbus server down (the device
// "disappears") and brings it back on the next SIGUSR1; the truth keeps running meanwhile.
#include <signal.h>
#include <time.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "config/load.hpp"
#include "plant_models/catalog.hpp"
#include "tests/simulator/simulation.hpp"
#include "tests/support/modbus_test_server.hpp"

namespace {

std::atomic<bool> g_stop{false};
std::atomic<int> g_toggles{0};

void on_signal(int sig) {
  if (sig == SIGUSR1)
    g_toggles.fetch_add(1);
  else
    g_stop = true;
}

void usage(std::FILE* to) {
  std::fputs(
      "usage: hvac-twin-sim --config FILE [options]\n"
      "\n"
      "Simulates the plant of one unit of an hvac-twin configuration and serves its sensor\n"
      "points over Modbus TCP on 127.0.0.1 (the port and unit id of the unit's modbus section).\n"
      "\n"
      "  --config FILE       hvac-twin configuration (the same file the daemon reads)\n"
      "  --unit ID           which unit (default: the first)\n"
      "  --port N            serve on this port instead of the configured one (0: ephemeral)\n"
      "  --seed N            random seed of the scenario and the sensor noise (default 1)\n"
      "  --time-scale X      model seconds per wall second (default: runtime.time_scale)\n"
      "  --step S            model seconds per truth step (default 5)\n"
      "  --noise-scale X     sensor noise = X * the unit's measurement_noise (default 1)\n"
      "  --set NAME=VALUE    a truth parameter differing from the configuration (repeatable),\n"
      "                      e.g. --set cond_ua_air=690 for a fouled outdoor coil\n"
      "  --as-configured     heat pump: simulate the configured model itself, not the truth's\n"
      "                      cell count and closures (Smith slip, quality-dependent two-phase\n"
      "                      heat transfer, friction ~ mdot^1.75 by specific volume)\n"
      "  --leak G@H          heat pump: a refrigerant leak of G g/h from hour H of the scenario\n"
      "  --charge KG         heat pump: the truth's refrigerant charge (default: nameplate)\n"
      "  --point NAME=V@H1-H2  the point NAME reads V (in its own unit) from hour H1 to H2 of\n"
      "                      the scenario: a transmitter gone wrong (repeatable)\n"
      "  --bias NAME=D       the point NAME reads D (in its own unit) above the truth\n"
      "                      throughout: a miscalibrated transmitter (repeatable)\n"
      "  --truth-csv FILE    write the simulated truth, one row per step\n"
      "  --state FILE        continue the plant saved in FILE, if it is there (model time,\n"
      "                      states, inputs, the scenario's draws and controllers), and\n"
      "                      save it there after every step: a restarted simulator goes on\n"
      "                      with the same plant (the demo's; remove FILE to start over)\n"
      "  --commissioning     heat pump: hold six operating points for 45 min each instead of\n"
      "                      the day's thermostat and superheat loops\n"
      "  --write-points F H  no Modbus server: simulate H model hours as fast as possible and\n"
      "                      write every step's point values as a points CSV (the format\n"
      "                      hvac-twin-replay and hvac-twin-calibrate read), then exit\n"
      "  --any-unit-id       answer requests for every Modbus unit id, not only the unit's\n"
      "                      (one simulated plant serving many configured units: scale_bench)\n"
      "  --max-clients N     TCP connections served at once (default 16)\n"
      "  --duration S        stop after S wall seconds (default: run until SIGINT/SIGTERM)\n"
      "  --quiet             no progress lines\n"
      "\n"
      "SIGUSR1 stops the Modbus server; the next SIGUSR1 starts it again on the same port.\n",
      to);
}

std::int64_t now_ns(clockid_t id) {
  timespec ts{};
  clock_gettime(id, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void sleep_until(std::int64_t deadline_ns) {
  timespec ts{static_cast<time_t>(deadline_ns / 1'000'000'000),
              static_cast<long>(deadline_ns % 1'000'000'000)};
  while (!g_stop && clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

// --point: a point that reads a fixed value for a while, whatever the plant does; --bias: one
// that reads off by a fixed amount throughout (a miscalibrated transmitter).
struct PointOverride {
  std::string name;
  double value = 0.0, from_s = 0.0, to_s = 0.0;
  bool add = false;
};

void apply_overrides(const std::vector<PointOverride>& overrides,
                     const hvac_twin::config::UnitConfig& unit, double t,
                     std::vector<double>& values) {
  for (const PointOverride& o : overrides)
    for (std::size_t i = 0; i < values.size(); ++i)
      if (unit.points[i].name == o.name && t >= o.from_s && t < o.to_s)
        values[i] = o.add ? values[i] + o.value : o.value;
}

struct Args {
  std::string config, unit, truth_csv, points_csv, state;
  double points_hours = 0.0;
  long port = -1;
  long max_clients = 16;
  bool any_unit_id = false;
  double time_scale = 0.0, duration = 0.0;
  bool quiet = false;
  hvac_twin::sim::SimOptions sim;
  std::vector<PointOverride> overrides;
};

bool parse(int argc, char** argv, Args& a) {
  for (int i = 1; i < argc; ++i) {
    const std::string_view arg = argv[i];
    const char* v = i + 1 < argc ? argv[i + 1] : nullptr;
    auto take = [&]() {
      ++i;
      return std::string(v);
    };
    if (arg == "--quiet") {
      a.quiet = true;
    } else if (arg == "--as-configured") {
      a.sim.truth_closures = false;
    } else if (arg == "--commissioning") {
      a.sim.scenario.commissioning = true;
    } else if (arg == "--any-unit-id") {
      a.any_unit_id = true;
    } else if (v == nullptr) {
      return false;
    } else if (arg == "--config") {
      a.config = take();
    } else if (arg == "--unit") {
      a.unit = take();
    } else if (arg == "--truth-csv") {
      a.truth_csv = take();
    } else if (arg == "--state") {
      a.state = take();
    } else if (arg == "--write-points") {
      a.points_csv = take();
      if (i + 1 >= argc) return false;
      a.points_hours = std::stod(argv[++i]);
      if (!(a.points_hours > 0.0)) return false;
    } else if (arg == "--port") {
      a.port = std::stol(take());
    } else if (arg == "--max-clients") {
      a.max_clients = std::stol(take());
      if (a.max_clients < 1 || a.max_clients > 1000) return false;
    } else if (arg == "--seed") {
      a.sim.seed = std::stoull(take());
    } else if (arg == "--time-scale") {
      a.time_scale = std::stod(take());
    } else if (arg == "--step") {
      a.sim.step_s = std::stod(take());
    } else if (arg == "--noise-scale") {
      a.sim.noise_scale = std::stod(take());
    } else if (arg == "--duration") {
      a.duration = std::stod(take());
    } else if (arg == "--leak") {
      const std::string spec = take();
      const auto at = spec.find('@');
      a.sim.scenario.leak_g_per_h = std::stod(spec.substr(0, at));
      a.sim.scenario.leak_start_s =
          at == std::string::npos ? 0.0 : 3600.0 * std::stod(spec.substr(at + 1));
    } else if (arg == "--charge") {
      a.sim.scenario.charge_kg = std::stod(take());
    } else if (arg == "--point") {
      const std::string spec = take();
      const auto eq = spec.find('='), at = spec.find('@'), dash = spec.find('-', at);
      if (eq == std::string::npos || at == std::string::npos || dash == std::string::npos)
        return false;
      a.overrides.push_back({spec.substr(0, eq), std::stod(spec.substr(eq + 1, at - eq - 1)),
                             3600.0 * std::stod(spec.substr(at + 1, dash - at - 1)),
                             3600.0 * std::stod(spec.substr(dash + 1))});
    } else if (arg == "--bias") {
      const std::string spec = take();
      const auto eq = spec.find('=');
      if (eq == std::string::npos) return false;
      a.overrides.push_back({spec.substr(0, eq), std::stod(spec.substr(eq + 1)), 0.0,
                             std::numeric_limits<double>::infinity(), true});
    } else if (arg == "--set") {
      const std::string kv = take();
      const auto eq = kv.find('=');
      if (eq == std::string::npos) return false;
      a.sim.parameter_overrides[kv.substr(0, eq)] = std::stod(kv.substr(eq + 1));
    } else {
      return false;
    }
  }
  return !a.config.empty() && a.sim.step_s > 0.0 && (a.state.empty() || a.points_csv.empty());
}

// --state: continues the plant saved in `path`; false if there is none yet.
bool load_state(hvac_twin::sim::Simulation& sim, const std::string& path) {
  std::ifstream in(path);
  if (!in) {
    if (!std::filesystem::exists(path)) return false;
    throw std::runtime_error("--state " + path + ": cannot read it");
  }
  try {
    sim.restore(in);
  } catch (const std::runtime_error& e) {
    throw std::runtime_error("--state " + path + ": " + e.what() +
                             " (not a state this simulator saved for this configuration; remove "
                             "the file to start the plant over)");
  }
  return true;
}

// --state: the plant as it stands, whole or not at all (written beside, then renamed).
void save_state(const hvac_twin::sim::Simulation& sim, const std::string& path) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    sim.save(out);
    out.flush();
    if (!out) throw std::runtime_error("--state " + path + ": cannot write " + tmp);
  }
  std::filesystem::rename(tmp, path);
}

// --write-points: the points CSV of args.points_hours of the scenario, from 2026-07-01 08:00 UTC.
int write_points(hvac_twin::sim::Simulation& sim, const hvac_twin::config::UnitConfig& unit,
                 const Args& args) {
  std::FILE* out = std::fopen(args.points_csv.c_str(), "w");
  if (out == nullptr) throw std::runtime_error("cannot write " + args.points_csv);
  std::fprintf(out, "# hvac-twin-sim: unit %s, seed %llu%s\ntime", unit.id.c_str(),
               static_cast<unsigned long long>(args.sim.seed),
               args.sim.scenario.commissioning ? ", commissioning" : "");
  for (const auto& p : unit.points)
    std::fprintf(out, ",%s", p.name.c_str());
  std::fputc('\n', out);
  constexpr long long kStart = 1782892800;  // 2026-07-01T08:00:00Z
  std::ofstream truth;
  if (!args.truth_csv.empty()) {
    truth.open(args.truth_csv);
    if (!truth) throw std::runtime_error("cannot write " + args.truth_csv);
    sim.write_csv_header(truth);
  }
  std::vector<double> values(unit.points.size());
  while (true) {
    if (truth.is_open())
      sim.write_csv_row(truth, (kStart + static_cast<long long>(sim.time_s())) * 1'000'000'000);
    sim.point_values(values);
    apply_overrides(args.overrides, unit, sim.time_s(), values);
    std::fprintf(out, "%.3f", static_cast<double>(kStart) + sim.time_s());
    for (const double v : values)
      std::fprintf(out, ",%.6g", v);
    std::fputc('\n', out);
    if (sim.time_s() >= args.points_hours * 3600.0 - 1e-9) break;
    if (!sim.step()) {
      std::fprintf(stderr, "hvac-twin-sim: truth integration failed at t = %g s\n", sim.time_s());
      std::fclose(out);
      return 1;
    }
  }
  return std::fclose(out) == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  Args args;
  try {
    if (!parse(argc, argv, args)) {
      usage(stderr);
      return 2;
    }
  } catch (const std::exception&) {
    usage(stderr);
    return 2;
  }
  const auto loaded =
      hvac_twin::config::load_config_file(args.config, hvac_twin::plant::model_schemas());
  if (!loaded.errors.empty()) {
    std::fputs(hvac_twin::config::format_errors(loaded.errors, args.config).c_str(), stderr);
    return hvac_twin::config::kExitConfigError;
  }
  const auto& cfg = *loaded.config;
  const hvac_twin::config::UnitConfig* unit = &cfg.units.front();
  for (const auto& u : cfg.units)
    if (u.id == args.unit) unit = &u;
  if (!args.unit.empty() && unit->id != args.unit) {
    std::fprintf(stderr, "hvac-twin-sim: no unit \"%s\" in %s\n", args.unit.c_str(),
                 args.config.c_str());
    return 2;
  }
  for (const PointOverride& o : args.overrides) {
    if (std::none_of(unit->points.begin(), unit->points.end(),
                     [&](const auto& p) { return p.name == o.name; })) {
      std::fprintf(stderr, "hvac-twin-sim: --point/--bias %s: unit \"%s\" has no such point\n",
                   o.name.c_str(), unit->id.c_str());
      return 2;
    }
  }
  const double time_scale = args.time_scale > 0.0 ? args.time_scale : cfg.runtime.time_scale;

  struct sigaction sa {};
  sa.sa_handler = on_signal;
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  sigaction(SIGUSR1, &sa, nullptr);

  try {
    hvac_twin::sim::Simulation sim(*unit, args.sim);
    if (!args.points_csv.empty()) return write_points(sim, *unit, args);
    const bool resumed = !args.state.empty() && load_state(sim, args.state);
    hvac_twin::test_support::ModbusTestServerOptions so;
    so.port = static_cast<std::uint16_t>(args.port >= 0 ? args.port : unit->modbus.port);
    so.unit_id = unit->modbus.unit_id;
    so.max_clients = static_cast<int>(args.max_clients);
    if (args.any_unit_id) so.unit_id_policy = hvac_twin::test_support::UnitIdPolicy::kAnswerAny;
    hvac_twin::test_support::ModbusTestServer server(so);
    std::vector<double> values(unit->points.size());
    auto publish = [&] {
      sim.point_values(values);
      apply_overrides(args.overrides, *unit, sim.time_s(), values);
      for (std::size_t i = 0; i < values.size(); ++i)
        server.set_value(unit->points[i], values[i]);
    };
    publish();
    server.start();
    std::ofstream csv;
    if (!args.truth_csv.empty()) {
      csv.open(args.truth_csv);
      if (!csv) throw std::runtime_error("cannot write " + args.truth_csv);
      sim.write_csv_header(csv);
      sim.write_csv_row(csv, now_ns(CLOCK_REALTIME));
    }
    std::printf(
        "hvac-twin-sim: unit %s (%s), Modbus TCP 127.0.0.1:%u unit id %d, time scale %g, "
        "seed %llu\n",
        unit->id.c_str(), unit->model.type.c_str(), server.port(), so.unit_id, time_scale,
        static_cast<unsigned long long>(args.sim.seed));
    if (resumed)
      std::printf("hvac-twin-sim: continuing the plant saved in %s at t = %.2f h\n",
                  args.state.c_str(), sim.time_s() / 3600.0);
    std::fflush(stdout);

    const auto wall_step = static_cast<std::int64_t>(args.sim.step_s / time_scale * 1e9);
    const std::int64_t start = now_ns(CLOCK_MONOTONIC);
    const auto end = static_cast<std::int64_t>(args.duration * 1e9);
    int toggles_seen = 0;
    for (std::int64_t k = 1; !g_stop; ++k) {
      sleep_until(start + k * wall_step);
      if (g_stop || (end > 0 && now_ns(CLOCK_MONOTONIC) - start >= end)) break;
      if (!sim.step()) {
        std::fprintf(stderr, "hvac-twin-sim: truth integration failed at t = %g s\n", sim.time_s());
        return 1;
      }
      publish();
      if (csv.is_open()) sim.write_csv_row(csv, now_ns(CLOCK_REALTIME));
      if (!args.state.empty()) save_state(sim, args.state);
      for (const int t = g_toggles.load(); toggles_seen < t; ++toggles_seen) {
        if (server.running())
          server.stop();
        else
          server.start();
        std::printf("hvac-twin-sim: Modbus server %s\n", server.running() ? "up" : "down");
        std::fflush(stdout);
      }
      const auto per_hour = static_cast<std::int64_t>(3600.0 / args.sim.step_s);
      const auto steps = std::llround(sim.time_s() / args.sim.step_s);  // since t = 0
      if (!args.quiet && per_hour > 0 && steps % per_hour == 0) {
        std::printf("hvac-twin-sim: t = %5.1f h\n", sim.time_s() / 3600.0);
        std::fflush(stdout);
      }
    }
    server.stop();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hvac-twin-sim: %s\n", e.what());
    return 1;
  }
  return 0;
}
