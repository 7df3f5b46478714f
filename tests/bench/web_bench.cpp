// web_bench (issue 16): the dashboard's aims, measured.
//
//  1. Memory with a day of history: this process builds what hvac-twin-web runs (a Cyclone
//     participant and subscriber on lo, the HTTP server on 127.0.0.1, the Dashboard) and feeds
//     the Dashboard, through the same ingest() the DDS loop calls, a day of a heat pump's records
//     at the 5 s period for `--day-units` units (per cycle: 24 virtual sensors, their unit
//     estimate, 7 observations, health, leak diagnosis, 8 consistency entries; the daemon's
//     topics). Prints the RSS before and after, and the cost of the API's answers on that history.
//     Aim: under 50 MB with 10 units.
//  2. Latency and many clients: the built hvac-twin-web as a child process; this process
//     publishes `--units` heat pumps every `--period-ms` with real UnitPublishers over Cyclone on
//     lo; `--clients` event streams (each a browser's unit view) measure, per health record,
//     the time from its publication (its timestamp, taken just before the write) to its arrival
//     in the stream; one more stream never reads (a browser gone silent); the overview and a
//     unit's history are fetched every second meanwhile. Prints the latency percentiles, the
//     API's response times and hvac-twin-web's RSS. Aims: within 1 s; responsive with 50 units
//     and 10 browsers.
// Figures, not assertions: it fails only if hvac-twin-web dies or no event arrives.
//
// usage: web_bench [--short] [--day-units N] [--day-hours H] [--units N] [--clients N]
//                  [--seconds S] [--period-ms P] [--domain D]
#include <arpa/inet.h>
#include <httplib.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "io/dds/participant.hpp"
#include "io/dds/publisher.hpp"
#include "io/dds/security.hpp"
#include "io/web/dashboard.hpp"
#include "io/web/server.hpp"
#include "tests/bench/bench_stats.hpp"
#include "tests/integration/process.hpp"
#include "tests/support/scratch_dir.hpp"
#include "tests/unit/web/web_test_support.hpp"

namespace {

using hvac_twin::bench::percentile;
using namespace std::chrono_literals;
namespace dds = hvac_twin::dds;
namespace web = hvac_twin::web;

struct Args {
  bool short_mode = false;
  int day_units = 10;
  double day_hours = 24.0;
  int units = 50;
  int clients = 10;
  double seconds = 30.0;
  int period_ms = 1000;
  int domain = 204;  // hvac-twin-web's range (200..209)
};

Args parse(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    const auto next = [&] { return i + 1 < argc ? std::string(argv[++i]) : std::string("0"); };
    if (arg == "--short") {
      a.short_mode = true;
      a.day_units = 2;
      a.day_hours = 2.0;
      a.units = 10;
      a.clients = 3;
      a.seconds = 8.0;
    } else if (arg == "--day-units")
      a.day_units = std::stoi(next());
    else if (arg == "--day-hours")
      a.day_hours = std::stod(next());
    else if (arg == "--units")
      a.units = std::stoi(next());
    else if (arg == "--clients")
      a.clients = std::stoi(next());
    else if (arg == "--seconds")
      a.seconds = std::stod(next());
    else if (arg == "--period-ms")
      a.period_ms = std::stoi(next());
    else if (arg == "--domain")
      a.domain = std::stoi(next());
    else {
      std::fprintf(stderr, "web_bench: unknown option %s\n", arg.c_str());
      std::exit(64);
    }
  }
  return a;
}

std::int64_t realtime_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}
std::int64_t monotonic_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// VmRSS or VmHWM of a process [MB].
double status_mb(const std::string& pid, const std::string& field) {
  std::ifstream in("/proc/" + pid + "/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(field + ":", 0) == 0) return std::stod(line.substr(field.size() + 1)) / 1024.0;
  return -1.0;
}

// "u<n>", built by appending (GCC 12 warns falsely on "u" + std::to_string(n)).
std::string unit_name(int n) {
  std::string name = "u";
  name += std::to_string(n);
  return name;
}

hvac_twin::config::DdsConfig loopback(int domain) {
  hvac_twin::config::DdsConfig c;
  c.domain_id = domain;
  return c;  // lo, multicast off, unicast to 127.0.0.1: the defaults
}

const std::vector<std::string>& sensor_names() {
  static const std::vector<std::string> names = {"suction_pressure",
                                                 "discharge_pressure",
                                                 "cond_wall_temperature_in",
                                                 "cond_wall_temperature_out",
                                                 "evap_wall_temperature_in",
                                                 "evap_wall_temperature_out",
                                                 "zone_air_temperature",
                                                 "supply_air_temperature",
                                                 "compressor_power",
                                                 "condenser_outlet_pressure",
                                                 "valve_inlet_enthalpy",
                                                 "condenser_heat_flow",
                                                 "evaporator_heat_flow",
                                                 "cooling_capacity",
                                                 "refrigerant_mass_flow",
                                                 "discharge_temperature",
                                                 "superheat",
                                                 "subcooling",
                                                 "cop",
                                                 "charge",
                                                 "leak_rate",
                                                 "mass_temperature",
                                                 "internal_gains",
                                                 "outdoor_coil_fouling"};
  return names;
}
const std::vector<std::string>& point_names() {
  static const std::vector<std::string> names = {"suction_pressure",
                                                 "discharge_pressure",
                                                 "outdoor_coil_in_temp",
                                                 "outdoor_coil_out_temp",
                                                 "indoor_coil_in_temp",
                                                 "indoor_coil_out_temp",
                                                 "zone_temp"};
  return names;
}

// One cycle of one heat pump as the Subscriber delivers it: 42 records.
void cycle_records(const std::string& unit, std::uint64_t cycle, std::int64_t t,
                   std::vector<dds::Record>& out) {
  const double phase = static_cast<double>(cycle) / 720.0;
  dds::UnitEstimateRecord e;
  e.site = std::string("site");
  e.unit = unit;
  for (std::size_t i = 0; i < sensor_names().size(); ++i) {
    const double value = 1000.0 * (1.0 + static_cast<double>(i)) *
                         (1.0 + 0.1 * std::sin(phase + static_cast<double>(i)));
    dds::VirtualSensorRecord v = web::test::sensor(unit, sensor_names()[i], value, 0.02 * value, t);
    v.eng_unit = std::string("W");
    v.cycle = cycle;
    e.estimates.push_back({v.name, v.value, v.sigma, v.eng_unit});
    out.emplace_back(std::move(v));
  }
  e.quality = dds::EstimateQuality::kGood;
  e.timestamp_ns = t;
  e.cycle = cycle;
  out.emplace_back(std::move(e));
  for (const auto& p : point_names()) {
    dds::ObservationRecord o = web::test::observation(unit, p, t);
    o.value = 20.0 + std::sin(phase);
    o.predicted = o.value - 0.1;
    o.innovation = 0.1 * std::cos(phase * 7.0);
    o.innovation_variance = 0.04;
    o.test_ratio = o.innovation * o.innovation / 0.04;
    o.cycle = cycle;
    out.emplace_back(std::move(o));
    dds::ConsistencyRecord c;
    c.site = std::string("site");
    c.unit = unit;
    c.point = p;
    c.verdict = dds::ConsistencyVerdict::kInBand;
    c.timestamp_ns = t;
    out.emplace_back(std::move(c));
  }
  dds::HealthRecord h = web::test::health(unit, cycle, t);
  h.cycle_time_ms = 40.0;
  out.emplace_back(std::move(h));
  dds::LeakDiagnosticRecord l = web::test::leak(unit, dds::LeakState::kNormal, t);
  l.charge = 0.5 - 1e-6 * static_cast<double>(cycle);
  l.cycle = cycle;
  out.emplace_back(std::move(l));
}

void memory_part(const Args& a) {
  const std::string self = std::to_string(::getpid());
  web::Dashboard dashboard(web::StoreLimits{}, web::HubLimits{});
  const auto participant = dds::make_participant(loopback(a.domain));
  dds::Subscriber subscriber(*participant, "hvac_twin_bench_idle");
  web::ServerConfig sc;
  sc.listen.port = 0;
  web::Server server(sc, dashboard);
  server.start();
  const double rss0 = status_mb(self, "VmRSS");

  const auto cycles = static_cast<std::uint64_t>(a.day_hours * 3600.0 / 5.0);
  const std::int64_t t0 = realtime_ns() - static_cast<std::int64_t>(cycles) * 5'000'000'000;
  std::vector<dds::Record> batch;
  const auto start = std::chrono::steady_clock::now();
  for (std::uint64_t k = 0; k < cycles; ++k) {
    for (int u = 0; u < a.day_units; ++u) {
      batch.clear();
      cycle_records(unit_name(u), k, t0 + static_cast<std::int64_t>(k) * 5'000'000'000, batch);
      dashboard.ingest(batch, {}, monotonic_ns());
    }
  }
  const double feed_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double rss1 = status_mb(self, "VmRSS");
  std::printf(
      "memory: %d units x %.1f h at the 5 s period (%llu cycles x 42 records each) fed in %.1f s\n",
      a.day_units, a.day_hours, static_cast<unsigned long long>(cycles), feed_s);
  std::printf(
      "memory: RSS %.1f MB before the history, %.1f MB after (+%.1f MB, %.2f MB per unit; "
      "aim: under 50 MB with 10 units a day)\n",
      rss0, rss1, rss1 - rss0, (rss1 - rss0) / a.day_units);

  // What the API costs on that history.
  httplib::Client http("127.0.0.1", server.port());
  http.set_read_timeout(30, 0);
  for (const char* path : {"/api/overview", "/api/unit?site=site&unit=u0",
                           "/api/history?site=site&unit=u0&window=3600",
                           "/api/history?site=site&unit=u0&window=86400"}) {
    std::vector<double> ms;
    std::size_t bytes = 0;
    for (int i = 0; i < 10; ++i) {
      const auto s = std::chrono::steady_clock::now();
      const auto r = http.Get(path);
      ms.push_back(
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - s).count());
      bytes = r ? r->body.size() : 0;
    }
    std::printf("memory: GET %-45s %7zu bytes, median %.1f ms, max %.1f ms\n", path, bytes,
                percentile(ms, 0.5), percentile(ms, 1.0));
  }
  server.stop();
}

// A stream that never reads: a browser tab gone silent.
int silent_stream(int port, const std::string& unit) {
  const int sock = ::socket(AF_INET, SOCK_STREAM, 0);
  int small = 4096;
  ::setsockopt(sock, SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(port));
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::connect(sock, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) return -1;
  const std::string request =
      "GET /events?site=site&unit=" + unit + " HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n";
  (void)::send(sock, request.data(), request.size(), 0);
  return sock;
}

int latency_part(const Args& a) {
  hvac_twin::test::ScratchDir dir("web-bench");
  hvac_twin::test::Process child(HVAC_TWIN_WEB_EXE,
                                 {"--domain", std::to_string(a.domain), "--listen", "127.0.0.1:0",
                                  "--max-units", std::to_string(std::max(a.units, 64))},
                                 dir / "web.out", dir / "web.err");
  std::smatch m;
  std::string err;
  const bool up = hvac_twin::test::eventually(
      [&] { return std::regex_search(err = child.err(), m, std::regex(R"(127\.0\.0\.1:(\d+)/)")); },
      20s);
  if (!up) {
    std::fprintf(stderr, "web_bench: hvac-twin-web did not start: %s\n", child.err().c_str());
    return 1;
  }
  const int port = std::stoi(m[1].str());
  const std::string pid = std::to_string(child.pid());

  const auto participant = dds::make_participant(loopback(a.domain));
  std::vector<std::unique_ptr<dds::UnitPublisher>> publishers;
  for (int u = 0; u < a.units; ++u)
    publishers.push_back(std::make_unique<dds::UnitPublisher>(
        *participant, "hvac_twin", "site", unit_name(u), std::chrono::milliseconds(a.period_ms)));
  std::atomic<bool> stop{false};
  std::thread publishing([&] {
    std::vector<dds::EstimateEntry> entries;
    for (const auto& n : sensor_names())
      entries.push_back({n, 1000.0, 20.0, "W"});
    auto next = std::chrono::steady_clock::now();
    for (std::uint64_t cycle = 1; !stop; ++cycle) {
      for (auto& p : publishers) {
        const std::int64_t t = realtime_ns();
        for (const auto& n : sensor_names())
          p->publish(dds::VirtualSensorSample{.name = n,
                                              .value = 1000.0,
                                              .sigma = 20.0,
                                              .eng_unit = "W",
                                              .quality = dds::EstimateQuality::kGood,
                                              .timestamp_ns = t,
                                              .cycle = cycle});
        p->publish(dds::UnitEstimateSample{.estimates = entries,
                                           .quality = dds::EstimateQuality::kGood,
                                           .timestamp_ns = t,
                                           .cycle = cycle});
        for (const auto& pt : point_names()) {
          p->publish(dds::ObservationSample{.point = pt,
                                            .value = 20.0,
                                            .quality = dds::PointQuality::kGood,
                                            .innovation_variance = 0.04,
                                            .fused = true,
                                            .timestamp_ns = t,
                                            .cycle = cycle});
          p->publish(dds::ConsistencySample{.point = pt, .timestamp_ns = t, .cycle = cycle});
        }
        p->publish(dds::LeakDiagnosticSample{.hold = dds::LeakHold::kNone,
                                             .charge = 0.5,
                                             .charge_sigma = 0.02,
                                             .nameplate_charge = 0.5,
                                             .threshold = 6.9,
                                             .quality = dds::EstimateQuality::kGood,
                                             .timestamp_ns = t,
                                             .cycle = cycle});
        // The health sample last, stamped just before its write: what the streams time.
        p->publish(dds::HealthSample{.cycle = cycle,
                                     .cycle_time_ms = 40.0,
                                     .quality = dds::EstimateQuality::kGood,
                                     .modbus_connected = true,
                                     .timestamp_ns = realtime_ns()});
      }
      next += std::chrono::milliseconds(a.period_ms);
      std::this_thread::sleep_until(next);
    }
  });

  std::mutex mutex;
  std::vector<double> latencies;
  std::vector<std::thread> streams;
  std::atomic<int> connected{0};
  for (int c = 0; c < a.clients; ++c) {
    streams.emplace_back([&, c] {
      httplib::Client http("127.0.0.1", port);
      http.set_read_timeout(30, 0);
      std::string buffer;
      bool counted = false;
      const std::string unit = unit_name(c % a.units);
      http.Get(("/events?site=site&unit=" + unit).c_str(), [&](const char* data, std::size_t n) {
        if (!counted) {
          counted = true;
          ++connected;
        }
        buffer.append(data, n);
        for (std::size_t end; (end = buffer.find("\n\n")) != std::string::npos;
             buffer.erase(0, end + 2)) {
          const std::string event = buffer.substr(0, end);
          if (event.find("\"topic\":\"estimator_health\"") == std::string::npos) continue;
          const auto at = event.find("\"timestamp_ns\":");
          if (at == std::string::npos) continue;
          const double ms =
              static_cast<double>(realtime_ns() - std::stoll(event.substr(at + 15))) / 1e6;
          const std::lock_guard lock(mutex);
          latencies.push_back(ms);
        }
        return !stop;
      });
    });
  }
  const int silent = silent_stream(port, "u0");
  std::vector<double> overview_ms, history_ms;
  httplib::Client http("127.0.0.1", port);
  http.set_read_timeout(30, 0);
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(a.seconds);
  while (std::chrono::steady_clock::now() < end && child.running()) {
    std::this_thread::sleep_for(1s);
    auto s = std::chrono::steady_clock::now();
    const auto o = http.Get("/api/overview");
    overview_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - s).count());
    s = std::chrono::steady_clock::now();
    http.Get("/api/history?site=site&unit=u0&window=3600");
    history_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - s).count());
  }
  const double rss = status_mb(pid, "VmRSS"), hwm = status_mb(pid, "VmHWM");
  nlohmann::json overview;
  if (const auto o = http.Get("/api/overview"); o && o->status == 200)
    overview = nlohmann::json::parse(o->body);
  stop = true;
  publishing.join();
  for (auto& t : streams)
    t.join();
  if (silent >= 0) ::close(silent);
  const bool alive = child.running();
  child.signal(SIGTERM);
  const auto rc = child.wait(10s);

  std::printf(
      "latency: %d units every %d ms (%d samples/s), %d event streams + 1 that never reads, %.0f "
      "s\n",
      a.units, a.period_ms, a.units * 42 * 1000 / a.period_ms, a.clients, a.seconds);
  std::printf(
      "latency: %zu health records timed in %d streams: publication to stream median %.1f ms, "
      "p99 %.1f ms, max %.1f ms (aim: 1 s to the page)\n",
      latencies.size(), connected.load(), percentile(latencies, 0.5), percentile(latencies, 0.99),
      percentile(latencies, 1.0));
  std::printf(
      "latency: GET /api/overview (%zu units) median %.1f ms, max %.1f ms; GET 1 h history "
      "median %.1f ms, max %.1f ms\n",
      overview.is_object() ? overview["units"].size() : 0, percentile(overview_ms, 0.5),
      percentile(overview_ms, 1.0), percentile(history_ms, 0.5), percentile(history_ms, 1.0));
  std::printf("latency: hvac-twin-web RSS %.1f MB (peak %.1f MB); streams open %s, resyncs %s\n",
              rss, hwm, overview.is_object() ? overview["server"]["clients"].dump().c_str() : "?",
              overview.is_object() ? overview["server"]["resyncs"].dump().c_str() : "?");
  if (!alive || latencies.empty()) {
    std::fprintf(stderr, "web_bench: %s\n%s", alive ? "no event arrived" : "hvac-twin-web died",
                 child.err().c_str());
    return 1;
  }
  return rc == 0 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  const Args a = parse(argc, argv);
  std::signal(SIGPIPE, SIG_IGN);
  memory_part(a);
  return latency_part(a);
}
