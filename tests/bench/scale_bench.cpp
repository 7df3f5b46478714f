// scale_bench (issue 13 item 4): the daemon process itself with 1, 10, 50 and 200 heat-pump
// units at a 1 s period, on one core, against one simulator serving all of them.
//
// Each unit is the demo's heat pump (config/demo-heat-pump.json: its model, augmented states,
// points and noise) with its own Modbus unit id; all of them poll one hvac-twin-sim on
// 127.0.0.1, which answers every unit id from one simulated plant (--any-unit-id). The plant is
// the same for every unit, the work is not shared: each unit has its own poller, filter,
// checkpoints, recording and DDS samples. The daemon is pinned to one core (sched_setaffinity,
// inherited through posix_spawn), the simulator and this program to the other, so the figures
// are the daemon's alone. DDS stays on loopback with multicast off, as everywhere.
//
// Per unit count it waits until every unit has run `--warm-up-cycles` cycles (the cold start,
// which solves each unit's initial steady state, is not the steady load) and `--warm-up-s` have
// passed (past the filter's settling and release, 600 s and more in the demo's configuration, the
// load is that of steady operation; before, that of a gateway's restart), then for `--seconds`
// reads every unit's EstimatorHealth over DDS and prints: cycles run (health samples with a new
// cycle index) against ticks due (a cycle still running at its next tick skips that tick), the
// cycle-time percentiles over all units' cycles, deadline overruns, the daemon's CPU (share of its
// core, and per unit), and its RSS; at the end the RSS growth per unit. Figures, not assertions: it
// fails only if the daemon or the simulator dies or a unit never starts.
//
// usage: scale_bench [--short] [--units 1,10,50,200] [--seconds S] [--period S]
//                    [--warm-up-cycles N] [--warm-up-s S] [--domain D]
#include <sched.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "io/dds/participant.hpp"
#include "io/dds/subscriber.hpp"
#include "tests/bench/bench_stats.hpp"
#include "tests/integration/process.hpp"
#include "tests/support/scratch_dir.hpp"

namespace {

using hvac_twin::bench::percentile;

using hvac_twin::test::Process;
using Clock = std::chrono::steady_clock;

struct Args {
  std::vector<int> units{1, 10, 50, 200};
  double seconds = 60.0;
  double period_s = 1.0;
  int warm_up_cycles = 10;
  double warm_up_s = 0.0;  // and at least this long [s, wall]
  int domain = 93;
  bool short_mode = false;
};

std::vector<int> parse_list(const std::string& text) {
  std::vector<int> out;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');)
    out.push_back(std::stoi(item));
  return out;
}

bool parse(int argc, char** argv, Args& a) {
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const bool has_value = i + 1 < argc;
    if (arg == "--short") {
      a.short_mode = true;
      a.units = {1, 4};
      a.seconds = 15.0;
    } else if (arg == "--units" && has_value) {
      a.units = parse_list(argv[++i]);
    } else if (arg == "--seconds" && has_value) {
      a.seconds = std::stod(argv[++i]);
    } else if (arg == "--period" && has_value) {
      a.period_s = std::stod(argv[++i]);
    } else if (arg == "--warm-up-cycles" && has_value) {
      a.warm_up_cycles = std::stoi(argv[++i]);
    } else if (arg == "--warm-up-s" && has_value) {
      a.warm_up_s = std::stod(argv[++i]);
    } else if (arg == "--domain" && has_value) {
      a.domain = std::stoi(argv[++i]);
    } else {
      return false;
    }
  }
  for (const int n : a.units)
    if (n < 1 || n > 247) return false;  // Modbus unit ids 1..247
  return !a.units.empty() && a.seconds > 0.0 && a.period_s > 0.0;
}

// Runs the calling thread (and what it spawns afterwards) on one CPU.
void pin_to(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  CPU_SET(cpu, &set);
  if (sched_setaffinity(0, sizeof set, &set) != 0) std::perror("scale_bench: sched_setaffinity");
}

// The daemon's CPU time so far [s] (/proc/<pid>/stat utime + stime).
double cpu_seconds(pid_t pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const auto close = text.rfind(')');  // the command name may hold spaces
  if (close == std::string::npos) return 0.0;
  std::stringstream rest(text.substr(close + 2));
  std::string field;
  double ticks = 0.0;
  for (int i = 3; i <= 15 && rest >> field; ++i)
    if (i == 14 || i == 15) ticks += std::stod(field);
  return ticks / static_cast<double>(sysconf(_SC_CLK_TCK));
}

// A /proc/<pid>/status field in kB (VmRSS, VmHWM); 0 if absent.
double status_kb(pid_t pid, const std::string& key) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(f, line);)
    if (line.rfind(key + ":", 0) == 0) return std::stod(line.substr(key.size() + 1));
  return 0.0;
}

std::string unit_name(int k) {
  char name[16];
  std::snprintf(name, sizeof name, "hp%03d", k);
  return name;
}

// The demo's heat pump n times, units hp001.. with Modbus unit ids 1..n on one port.
nlohmann::json scale_config(const Args& a, int n, int port, const std::string& dir) {
  std::ifstream in(std::string(HVAC_TWIN_SOURCE_DIR) + "/config/demo-heat-pump.json");
  nlohmann::json c = nlohmann::json::parse(in);
  c["state_directory"] = dir + "/state";
  c["dds"]["domain_id"] = a.domain;
  c["runtime"]["time_scale"] = 1.0;
  c["runtime"]["log_level"] = "warn";
  const nlohmann::json unit = c["units"][0];
  c["units"] = nlohmann::json::array();
  for (int k = 1; k <= n; ++k) {
    nlohmann::json u = unit;
    u["id"] = unit_name(k);
    u["modbus"]["port"] = port;
    u["modbus"]["unit_id"] = k;
    u["estimator"]["period_s"] = a.period_s;
    u["estimator"]["deadline_s"] = a.period_s;
    c["units"].push_back(u);
  }
  return c;
}

void write_json(const std::string& path, const nlohmann::json& j) {
  std::ofstream(path) << j.dump(2) << '\n';
}

// A unit's health samples: `cycle` is the tick index (a skipped tick advances it), so the
// cycles run are the samples with a new index.
struct UnitTrack {
  std::uint64_t cycle = 0, overruns = 0, start_overruns = 0, runs = 0;
};

struct Row {
  int units = 0;
  double due = 0.0, cycles = 0.0, p50 = 0.0, p99 = 0.0, max = 0.0;
  std::uint64_t overruns = 0;
  double cpu_share = 0.0, rss_mib = 0.0, hwm_mib = 0.0;
  bool ok = false;
};

// One unit count: the simulator and the daemon, warm-up, then the measured window.
Row run_one(const Args& a, int n, int sim_cpu, int daemon_cpu) {
  Row row;
  row.units = n;
  hvac_twin::test::ScratchDir dir("scale-bench-" + std::to_string(n));
  const std::string config = dir / "config.json";
  write_json(config, scale_config(a, n, 1, dir.path().string()));  // the sim: --port 0

  pin_to(sim_cpu);
  Process sim(HVAC_TWIN_SIM_EXE,
              {"--config", config, "--port", "0", "--any-unit-id", "--max-clients",
               std::to_string(n + 8), "--time-scale", "1", "--step", "1", "--quiet"},
              dir / "sim.out", dir / "sim.err");
  int port = 0;
  hvac_twin::test::eventually(
      [&] {
        const std::string out = sim.out();
        const auto at = out.find("127.0.0.1:");
        if (at != std::string::npos) port = std::atoi(out.c_str() + at + 10);
        return port > 0 || !sim.running();
      },
      std::chrono::seconds(30));
  if (port <= 0) {
    std::fprintf(stderr, "scale_bench: the simulator did not start:\n%s\n", sim.err().c_str());
    return row;
  }
  write_json(config, scale_config(a, n, port, dir.path().string()));

  pin_to(daemon_cpu);
  Process daemon(HVAC_TWIND_EXE, {"--config", config}, dir / "daemon.out", dir / "daemon.err");
  pin_to(sim_cpu);

  hvac_twin::config::DdsConfig dds;
  dds.domain_id = a.domain;
  hvac_twin::dds::Participant participant(dds);
  hvac_twin::dds::TopicSet topics{false, false, true, false, false, false};
  hvac_twin::dds::Subscriber subscriber(participant, "hvac_twin", topics);

  std::map<std::string, UnitTrack> units;
  std::vector<double> cycle_ms;
  std::vector<hvac_twin::dds::Record> records;
  bool measuring = false;
  const auto started = Clock::now();
  const auto warm_up_min = started + std::chrono::duration_cast<Clock::duration>(
                                         std::chrono::duration<double>(a.warm_up_s));
  const auto warm_up_end = warm_up_min + std::chrono::seconds(60 + 3 * n);
  Clock::time_point measure_start, measure_end;
  double cpu_start = 0.0;
  while (true) {
    if (!daemon.running() || !sim.running()) {
      std::fprintf(stderr, "scale_bench: %s exited at %d units:\n%s\n",
                   daemon.running() ? "the simulator" : "the daemon", n,
                   (daemon.running() ? sim.err() : daemon.err()).c_str());
      return row;
    }
    records.clear();
    subscriber.wait_and_take(std::chrono::milliseconds(100), records);
    for (const auto& r : records) {
      const auto* h = std::get_if<hvac_twin::dds::HealthRecord>(&r);
      if (h == nullptr) continue;
      UnitTrack& u = units[h->unit];
      if (measuring && h->cycle > u.cycle) {
        cycle_ms.push_back(h->cycle_time_ms);
        ++u.runs;
      }
      u.cycle = std::max(u.cycle, h->cycle);
      u.overruns = std::max(u.overruns, h->overruns);
    }
    const auto now = Clock::now();
    if (!measuring) {
      const auto warmed = [&](const auto& kv) {
        return kv.second.cycle >= static_cast<std::uint64_t>(a.warm_up_cycles);
      };
      const auto n_warm = static_cast<int>(std::count_if(units.begin(), units.end(), warmed));
      const bool warm = now >= warm_up_min && n_warm == n;
      if (warm) {
        measuring = true;
        measure_start = now;
        measure_end = now + std::chrono::duration_cast<Clock::duration>(
                                std::chrono::duration<double>(a.seconds));
        cpu_start = cpu_seconds(daemon.pid());
        for (auto& [name, u] : units)
          u.start_overruns = u.overruns;
      } else if (now > warm_up_end) {
        std::fprintf(stderr, "scale_bench: %d of %d units ran %d cycles within the warm-up\n",
                     n_warm, n, a.warm_up_cycles);
        return row;
      }
    } else if (now >= measure_end) {
      break;
    }
  }
  const double wall = std::chrono::duration<double>(Clock::now() - measure_start).count();
  row.cpu_share = (cpu_seconds(daemon.pid()) - cpu_start) / wall;
  row.rss_mib = status_kb(daemon.pid(), "VmRSS") / 1024.0;
  row.hwm_mib = status_kb(daemon.pid(), "VmHWM") / 1024.0;
  row.due = wall / a.period_s * n;
  for (const auto& [name, u] : units) {
    row.cycles += static_cast<double>(u.runs);
    row.overruns += u.overruns - u.start_overruns;
  }
  row.p50 = percentile(cycle_ms, 0.5);
  row.p99 = percentile(cycle_ms, 0.99);
  row.max = cycle_ms.empty() ? 0.0 : *std::max_element(cycle_ms.begin(), cycle_ms.end());
  row.ok = true;
  daemon.signal(SIGTERM);
  if (!daemon.wait(std::chrono::seconds(30))) std::fprintf(stderr, "scale_bench: daemon hung\n");
  sim.signal(SIGTERM);
  sim.wait(std::chrono::seconds(10));
  return row;
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  if (!parse(argc, argv, a)) {
    std::fputs(
        "usage: scale_bench [--short] [--units 1,10,50,200] [--seconds S] [--period S]\n"
        "                   [--warm-up-cycles N] [--warm-up-s S] [--domain D]\n"
        "  --short: 1 and 4 units for 15 s (CI)\n",
        stderr);
    return 2;
  }
  const long cpus = sysconf(_SC_NPROCESSORS_ONLN);
  const int daemon_cpu = 0;
  const int sim_cpu = cpus > 1 ? 1 : 0;
  std::printf(
      "scale_bench: the demo heat pump x N at a %.3g s period, the daemon pinned to CPU %d, the\n"
      "simulator and this reader to CPU %d; %.0f s measured after %d warm-up cycles per unit\n\n",
      a.period_s, daemon_cpu, sim_cpu, a.seconds, a.warm_up_cycles);
  std::printf("%6s %14s %9s %9s %9s %9s %12s %12s %9s %9s\n", "units", "cycles/due", "p50 ms",
              "p99 ms", "max ms", "overruns", "CPU % core", "CPU %/unit", "RSS MiB", "peak MiB");
  std::vector<Row> rows;
  bool failed = false;
  for (const int n : a.units) {
    const Row r = run_one(a, n, sim_cpu, daemon_cpu);
    if (!r.ok) {
      failed = true;
      std::printf("%6d  failed (see above)\n", n);
      continue;
    }
    rows.push_back(r);
    std::printf("%6d %6.0f/%-7.0f %9.2f %9.2f %9.2f %9llu %12.1f %12.2f %9.1f %9.1f\n", n, r.cycles,
                r.due, r.p50, r.p99, r.max, static_cast<unsigned long long>(r.overruns),
                100.0 * r.cpu_share, 100.0 * r.cpu_share / n, r.rss_mib, r.hwm_mib);
    std::fflush(stdout);
  }
  if (rows.size() >= 2) {
    const Row& lo = rows.front();
    const Row& hi = rows.back();
    std::printf("\nRSS growth per unit (%d -> %d units): %.2f MiB\n", lo.units, hi.units,
                (hi.rss_mib - lo.rss_mib) / (hi.units - lo.units));
  }
  for (const Row& r : rows) {
    if (r.units != 200) continue;
    const bool met = r.overruns == 0 && r.cycles >= 0.99 * r.due;
    std::printf("aim: 200 units at 1 Hz on one core with no deadline miss: %s\n",
                met ? "met" : "MISSED");
  }
  return failed ? 1 : 0;
}
