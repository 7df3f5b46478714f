// The filter's consistency on hvac_twin/estimator_consistency, end to end: the zone daemon
// against its simulator at 1200x, a real Cyclone reader in this process (loopback only).
//  - every cycle, one sample per measured point and one for all points ("*"), with the window,
//    the samples in it, the mean NIS and its chi-square band;
//  - sensor noise twice what the filter is told (the simulator's --noise-scale): HIGH, logged
//    once; back at the told noise the episode ends, logged once.
#include <catch2/catch.hpp>
#include <chrono>
#include <cmath>
#include <map>
#include <thread>

#include "io/dds/participant.hpp"
#include "io/dds/subscriber.hpp"
#include "stack.hpp"

using namespace hvac_twin;
using namespace hvac_twin::test;
using namespace std::chrono_literals;

namespace {

// The zone demo at the Stack's defaults: a 120 s model cycle every 0.1 s of wall time, so the
// default window of 3600 s is 30 cycles (3 s).
constexpr auto kWallPeriod = std::chrono::milliseconds(100);
constexpr std::uint32_t kWindow = 30;

dds::TopicSet consistency_only() {
  return dds::TopicSet{false, false, false, false, true, false};
}

config::DdsConfig reader_config(int domain) {
  config::DdsConfig c;
  c.domain_id = domain;
  return c;  // lo, unicast to 127.0.0.1, multicast off: the defaults
}

// The newest record per point, and every record, taken until `done(newest)` holds or `timeout`.
struct Seen {
  std::map<std::string, dds::ConsistencyRecord> newest;
  std::vector<dds::ConsistencyRecord> all;
};
template <class F>
bool watch(dds::Subscriber& sub, Seen& seen, F done, std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  std::vector<dds::Record> got;
  while (std::chrono::steady_clock::now() < end) {
    got.clear();
    sub.wait_and_take(100ms, got);
    for (const auto& r : got) {
      const auto& c = std::get<dds::ConsistencyRecord>(r);
      seen.newest[c.point] = c;
      seen.all.push_back(c);
    }
    if (done(seen.newest)) return true;
  }
  return false;
}

// `what` appears in `text` exactly once.
bool once(const std::string& text, const std::string& what) {
  const auto first = text.find(what);
  return first != std::string::npos && first == text.rfind(what);
}

// How often `what` appears in `text`.
int count(const std::string& text, const std::string& what) {
  int n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1))
    ++n;
  return n;
}

}  // namespace

TEST_CASE("estimator_consistency carries every measured point and \"*\" every cycle",
          "[integration][consistency][dds]") {
  StackOptions o;
  o.domain_id = 66;
  Stack stack("consistency", o);
  dds::Participant participant(reader_config(o.domain_id));
  dds::Subscriber reader(participant, "hvac_twin", consistency_only(), kWallPeriod);
  stack.start_sim();
  stack.start_daemon();
  Seen seen;
  // Until the window is full: a verdict for the point, pooled and per point.
  const bool full = watch(
      reader, seen,
      [](const auto& newest) {
        return newest.contains("zone_temp") && newest.at("zone_temp").samples == kWindow &&
               newest.contains("*") && newest.at("*").samples == kWindow;
      },
      30s);
  INFO("daemon stderr:\n" << stack.daemon().err());
  REQUIRE(full);
  watch(
      reader, seen, [](const auto&) { return false; }, 1s);  // ten more cycles

  std::map<std::string, std::uint64_t> last_cycle;
  std::map<std::uint64_t, std::map<std::string, dds::ConsistencyRecord>> by_cycle;
  for (const auto& c : seen.all) {
    INFO("point " << c.point << " cycle " << c.cycle << " samples " << c.samples << " mean "
                  << c.mean_nis << " band [" << c.band_low << ", " << c.band_high << "]");
    CHECK(c.site == "demo-site");
    CHECK(c.unit == "zone1");
    CHECK((c.point == "zone_temp" || c.point == "*"));  // the one measured point, and all
    CHECK(c.window_cycles == kWindow);
    CHECK(c.samples <= kWindow);  // one measured point: at most one sample per cycle
    if (last_cycle.contains(c.point))
      CHECK(c.cycle > last_cycle[c.point]);  // one sample per cycle and key, in order
    last_cycle[c.point] = c.cycle;
    by_cycle[c.cycle][c.point] = c;
    CHECK(c.rejected_share >= 0.0);
    CHECK(c.rejected_share <= 1.0);
    if (c.samples == 0) {
      CHECK(c.verdict == dds::ConsistencyVerdict::kInsufficientData);
      continue;
    }
    CHECK(std::isfinite(c.mean_nis));
    CHECK(c.mean_nis > 0.0);
    CHECK(c.band_low < 1.0);
    CHECK(c.band_high > 1.0);
    CHECK(c.timestamp_ns == c.source_timestamp_ns);
    if (c.samples == kWindow) {  // chi2(30) / 30: 16.791 / 30 and 46.979 / 30
      CHECK(c.band_low == Approx(0.55969).epsilon(1e-4));
      CHECK(c.band_high == Approx(1.56597).epsilon(1e-4));
      CHECK(c.verdict != dds::ConsistencyVerdict::kInsufficientData);
    }
  }
  // Both keys in every cycle (the reader may have stopped between the two of the last one), and
  // with one measured point the pooled figure is that point's.
  std::size_t both = 0;
  for (const auto& [cycle, points] : by_cycle) {
    INFO("cycle " << cycle);
    if (cycle != by_cycle.rbegin()->first) CHECK(points.size() == 2);
    if (points.size() != 2) continue;
    ++both;
    CHECK(points.at("*").samples == points.at("zone_temp").samples);
    CHECK(points.at("*").mean_nis == Approx(points.at("zone_temp").mean_nis));
    CHECK(points.at("*").verdict == points.at("zone_temp").verdict);
  }
  CHECK(both >= kWindow + 5);
  // The filter is told the simulator's true noise: nowhere near the sigmas-too-small test below
  // (seen: 0.98 in [0.56, 1.57]; not required in band, the samples are autocorrelated).
  const auto& point = seen.newest.at("zone_temp");
  CHECK(point.mean_nis < 2.0 * point.band_high);
  stack.daemon().signal(SIGTERM);
  stack.daemon().wait(10s);
}

TEST_CASE("sigmas too small are flagged HIGH and logged once, and the episode ends, logged once",
          "[integration][consistency][dds]") {
  StackOptions o;
  o.domain_id = 67;
  // The zone sensor's noise twice what the filter is told: NIS ~ 3, a few per cent rejected.
  // (Until the EKF let a unit's only point back in after a streak of rejections, a cold-start
  // transient could leave this single-sensor filter 2 K off its sensor for good: seen in one run
  // of six here, and in 4 of 12 runs of the next case under the sanitizers.)
  o.sim_args = {"--noise-scale", "2"};
  // A window of 90 cycles (9 s): its mean NIS (~3 here, ~1 at the told noise) has a spread of
  // 0.45 (0.15), far from the band's top at 1.31: no flapping between verdicts in this test.
  o.customize = [](nlohmann::json& c) {
    c["units"][0]["estimator"]["consistency_window_s"] = 90 * 120.0;
  };
  Stack stack("consistency-high", o);
  dds::Participant participant(reader_config(o.domain_id));
  dds::Subscriber reader(participant, "hvac_twin", consistency_only(), kWallPeriod);
  const int port = stack.start_sim();
  stack.start_daemon();
  Seen seen;
  const auto high = [](const auto& newest) {
    return newest.contains("zone_temp") &&
           newest.at("zone_temp").verdict == dds::ConsistencyVerdict::kHigh &&
           newest.contains("*") && newest.at("*").verdict == dds::ConsistencyVerdict::kHigh;
  };
  const bool flagged = watch(reader, seen, high, 30s);
  INFO("daemon stderr:\n" << stack.daemon().err());
  REQUIRE(flagged);
  const auto& c = seen.newest.at("zone_temp");
  INFO("mean NIS " << c.mean_nis << " band [" << c.band_low << ", " << c.band_high << "], rejected "
                   << c.rejected_share);
  CHECK(c.window_cycles == 90);
  // A full window and more of it: still HIGH, and the log said so once per figure, not per cycle.
  watch(
      reader, seen, [](const auto&) { return false; }, 10s);
  CHECK(high(seen.newest));
  CHECK(seen.newest.at("zone_temp").samples == 90);
  const std::string during = stack.daemon().err();
  CHECK(once(during, "point zone_temp: innovations larger than the filter expects"));
  CHECK(once(during, "all measured points: innovations larger"));
  CHECK(during.find("consistent again") == std::string::npos);

  // The sensor back at the noise the filter is told (the simulator restarted, as a device
  // returning): the episode ends, once.
  stack.stop_sim();
  stack.set_sim_args({});
  stack.start_sim(port);
  const bool recovered = eventually(
      [&] { return once(stack.daemon().err(), "point zone_temp: innovations consistent again"); },
      60s);
  CHECK(recovered);
  // The topic says so too. Afterwards the single-sensor filter may lose track again for a while
  // (seen once under the sanitizers, 3 s after the recovery): a new episode, logged as such.
  // Logged once per episode either way: one warning per episode, one end per ended episode.
  const bool not_high = watch(
      reader, seen,
      [](const auto& newest) {
        return newest.contains("zone_temp") &&
               newest.at("zone_temp").verdict != dds::ConsistencyVerdict::kHigh;
      },
      10s);
  const std::string after = stack.daemon().err();
  INFO("daemon stderr:\n" << after);
  CHECK(not_high);
  const int episodes = count(after, "point zone_temp: innovations larger");
  const int ended = count(after, "point zone_temp: innovations consistent again");
  CHECK(ended >= 1);
  CHECK((episodes == ended || episodes == ended + 1));
  stack.daemon().signal(SIGTERM);
  stack.daemon().wait(10s);
}

TEST_CASE("adaptive noise: the filter's own NIS back near 1, the told noise still judged HIGH",
          "[integration][consistency][dds]") {
  StackOptions o;
  o.domain_id = 69;
  // The sensor twice as noisy as told (variance x4), the daemon allowed to inflate it up to x9
  // (estimator.adaptive_noise_max), over a window of 90 cycles (9 s).
  o.sim_args = {"--noise-scale", "2"};
  o.customize = [](nlohmann::json& c) {
    c["units"][0]["estimator"]["consistency_window_s"] = 90 * 120.0;
    c["units"][0]["estimator"]["adaptive_noise_max"] = 9.0;
  };
  Stack stack("consistency-adaptive", o);
  dds::Participant participant(reader_config(o.domain_id));
  dds::Subscriber reader(participant, "hvac_twin",
                         dds::TopicSet{false, true, false, false, true, false}, kWallPeriod);
  stack.start_sim();
  stack.start_daemon();
  // Three windows: the first to learn the noise, then what the filter and the monitor say.
  std::vector<dds::ObservationRecord> observations;
  dds::ConsistencyRecord newest;
  const auto end = std::chrono::steady_clock::now() + 27s;
  std::vector<dds::Record> got;
  while (std::chrono::steady_clock::now() < end) {
    got.clear();
    reader.wait_and_take(100ms, got);
    for (const auto& r : got) {
      if (const auto* obs = std::get_if<dds::ObservationRecord>(&r))
        observations.push_back(*obs);
      else if (const auto* c = std::get_if<dds::ConsistencyRecord>(&r);
               c != nullptr && c->point == "zone_temp")
        newest = *c;
    }
  }
  const std::string log = stack.daemon().err();
  INFO("daemon stderr:\n" << log);
  REQUIRE(observations.size() > 200);
  // The filter's own NIS over the last 120 cycles (its noise learnt): about 1, where told the
  // simulator's noise it would be about 4 (the sensor's variance x4, the prior's share small).
  double sum = 0.0;
  int n = 0;
  for (auto it = observations.rbegin(); it != observations.rend() && n < 120; ++it, ++n)
    sum += it->test_ratio;
  const double own_nis = sum / n;
  INFO("the filter's own mean NIS " << own_nis << "; the monitor's against the told noise "
                                    << newest.mean_nis << " (" << newest.samples << " samples)");
  CHECK(own_nis > 0.6);
  CHECK(own_nis < 1.6);
  // Nothing hidden: judged against the noise the filter was told, the sensor is still HIGH.
  CHECK(newest.verdict == dds::ConsistencyVerdict::kHigh);
  CHECK(once(log, "point zone_temp: innovations larger than the filter expects"));
  stack.daemon().signal(SIGTERM);
  stack.daemon().wait(10s);
}
