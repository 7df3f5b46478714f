// A restarted daemon resumes from its checkpoint (issue 6): killed with SIGKILL and started
// again, the heat-pump daemon continues its charge estimate (same value, same small sigma) and
// its leak evidence (decisions, no second warm-up) instead of starting over; with the checkpoint
// removed the same restart is a cold start (the negative control: the test can fail).
#include <catch2/catch.hpp>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <span>
#include <thread>

#include "daemon/runtime/checkpoint.hpp"
#include "io/dds/participant.hpp"
#include "io/dds/subscriber.hpp"
#include "plant_models/catalog.hpp"
#include "stack.hpp"
#include "strace_support.hpp"

using namespace hvac_twin;
using namespace hvac_twin::test;
using namespace std::chrono_literals;

namespace {

constexpr int kDomain = 58;

StackOptions resume_options() {
  StackOptions o = heat_pump_stack_options(kDomain);
  o.customize = [base = o.customize](nlohmann::json& c) {
    base(c);  // the topics and the daemon's life are under test here, not the model's accuracy
    auto& e = c["units"][0]["estimator"];
    e["checkpoint_every_cycles"] = 4;
    // Short warm-up and decisions, so the detector has history worth keeping within seconds.
    e["leak_detection"] = {
        {"warm_up_s", 30.0}, {"interval_s", 20.0}, {"startup_s", 0.0}, {"reference_s", 40.0}};
  };
  return o;
}

// A reader's DDS configuration: lo, unicast to 127.0.0.1, multicast off (the defaults).
config::DdsConfig loopback_dds(int domain) {
  config::DdsConfig c;
  c.domain_id = domain;
  return c;
}

// The newest charge estimate and leak diagnosis of one daemon run, from cycle `min_cycle` on.
struct Seen {
  std::optional<dds::VirtualSensorRecord> charge;
  std::optional<dds::LeakDiagnosticRecord> leak;
  std::optional<dds::VirtualSensorRecord> first_charge;  // the run's first samples
  std::optional<dds::LeakDiagnosticRecord> first_leak;
};

runtime::DecodedCheckpoint read_checkpoint(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(file)), {});
  return runtime::decode_checkpoint(
      std::as_bytes(std::span<const char>(bytes.data(), bytes.size())));
}

// Rewrites the checkpoint at `path` changed by `edit` (a valid checksum again).
template <class Edit>
void rewrite_checkpoint(const std::string& path, Edit edit) {
  const auto decoded = read_checkpoint(path);
  REQUIRE(decoded.ok());
  runtime::FilterSnapshot s = decoded.snapshot;
  edit(s);
  std::vector<std::byte> out(runtime::checkpoint_size(s));
  REQUIRE(runtime::encode_checkpoint(s, out) == out.size());
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(out.data()), static_cast<std::streamsize>(out.size()));
}

void watch(dds::Subscriber& sub, Seen& seen, std::chrono::milliseconds how_long) {
  const auto end = std::chrono::steady_clock::now() + how_long;
  std::vector<dds::Record> got;
  while (std::chrono::steady_clock::now() < end) {
    got.clear();
    sub.wait_and_take(100ms, got);
    for (const auto& r : got) {
      if (const auto* v = std::get_if<dds::VirtualSensorRecord>(&r); v && v->name == "charge") {
        if (!seen.first_charge) seen.first_charge = *v;
        seen.charge = *v;
      }
      if (const auto* l = std::get_if<dds::LeakDiagnosticRecord>(&r)) {
        if (!seen.first_leak) seen.first_leak = *l;
        seen.leak = *l;
      }
    }
  }
}

}  // namespace

TEST_CASE("a daemon killed with SIGKILL resumes from its checkpoint, without it, a cold start",
          "[integration][checkpoint]") {
  Stack stack("resume", resume_options());
  stack.start_sim();
  dds::Participant participant(loopback_dds(kDomain));
  dds::Subscriber reader(
      participant, "hvac_twin",
      dds::TopicSet{true, false, false, true, false, false});  // virtual_sensor, leak

  // First run: long enough for several checkpoints and leak decisions.
  stack.start_daemon();
  Seen before;
  watch(reader, before, 12s);
  const std::string first_log = stack.daemon().err();
  INFO("first run:\n" << first_log);
  stack.daemon().signal(SIGKILL);
  REQUIRE(stack.daemon().wait(5s).has_value());
  REQUIRE(before.charge.has_value());
  REQUIRE(before.leak.has_value());
  CHECK((before.first_charge->flags & dds::kFlagColdStart) != 0);
  CHECK(before.leak->decisions >= 2);
  CHECK(before.leak->hold != dds::LeakHold::kWarmUp);
  CHECK_THAT(first_log, Catch::Contains("learnt its reference charges"));
  // The filter learnt the charge: its own sigma, the published one without the model's
  // structural error in the charge (SignalInfo::model_error_rel), halved at least.
  const plant::SignalInfo charge_info = [] {
    const auto layout = plant::create_model("heat_pump_r32", {})->layout();
    return layout.outputs[*layout.output("charge")];
  }();
  const auto own_sigma = [&](const dds::VirtualSensorRecord& v) {
    const double structural = charge_info.model_error_rel * v.value;
    return std::sqrt(std::max(0.0, v.sigma * v.sigma - structural * structural));
  };
  REQUIRE(charge_info.model_error_rel > 0.0);
  const double initial_sigma = own_sigma(*before.first_charge);
  CHECK(own_sigma(*before.charge) < 0.5 * initial_sigma);
  const std::string ckpt = stack.path("state/hp1.ckpt");
  REQUIRE(std::filesystem::exists(ckpt));
  // Whether the filter was still converging (flag cold_start) when the checkpoint was saved.
  const auto saved = read_checkpoint(ckpt);
  REQUIRE(saved.ok());
  const bool saved_converging = (saved.snapshot.flags & runtime::kSnapshotConverging) != 0;
  // Saved within the parameter hold (the first run is about 120 of its 600 model seconds): the
  // resumed filter ramps the parameters in again rather than releasing them at once.
  CHECK((saved.snapshot.flags & runtime::kSnapshotReleasing) != 0);

  // Second run, same state directory: resumes.
  std::vector<dds::Record> drain;
  reader.take(drain);
  const std::size_t first_run_bytes = stack.daemon().err().size();  // the log file appends
  stack.start_daemon();
  Seen after;
  watch(reader, after, 4s);
  INFO("second run:\n" << stack.daemon().err());
  const std::string second_log = stack.daemon().err().substr(first_run_bytes);
  CHECK_THAT(second_log, Catch::Contains("resumed from checkpoint"));
  CHECK_THAT(second_log, Catch::Contains("fully released: released again over 120 s"));
  // The log says what the detector resumed with, and does not announce as new what it had.
  CHECK(regex_find(second_log,
                   "leak detector state NORMAL, [1-9][0-9]* decisions, reference charges [0-9]+-")
            .has_value());
  CHECK_THAT(second_log, !Catch::Contains("learnt its reference charges"));
  REQUIRE(after.first_charge.has_value());
  REQUIRE(after.leak.has_value());
  // A resume keeps the flag as saved: a filter saved while converging is still converging.
  CHECK(((after.first_charge->flags & dds::kFlagColdStart) != 0) == saved_converging);
  CHECK((second_log.find("still converging: flag cold_start") != std::string::npos) ==
        saved_converging);
  // The charge continues: the same estimate (within what the last few cycles moved it) with the
  // small sigma it had, not the cold-start sigma.
  CHECK(after.first_charge->value == Approx(before.charge->value).margin(0.01));
  CHECK(own_sigma(*after.first_charge) < 0.5 * initial_sigma);
  // The leak evidence continues: no second warm-up, decisions counted on from the checkpoint.
  CHECK(after.first_leak->decisions >= before.leak->decisions - 1);  // at most 4 cycles lost
  CHECK(after.first_leak->hold != dds::LeakHold::kWarmUp);
  stack.daemon().signal(SIGKILL);
  REQUIRE(stack.daemon().wait(5s).has_value());

  // The other case, whichever the run above saved: the checkpoint rewritten with the flag
  // flipped (flags and checksum) resumes with the flag flipped.
  rewrite_checkpoint(ckpt, [&](runtime::FilterSnapshot& c) {
    REQUIRE(((c.flags & runtime::kSnapshotConverging) != 0) == saved_converging);
    c.flags ^= runtime::kSnapshotConverging;
  });
  reader.take(drain);
  const std::size_t second_run_bytes = stack.daemon().err().size();
  stack.start_daemon();
  Seen flipped;
  watch(reader, flipped, 3s);
  const std::string flipped_log = stack.daemon().err().substr(second_run_bytes);
  INFO("run from the flipped checkpoint:\n" << flipped_log);
  REQUIRE(flipped.first_charge.has_value());
  CHECK(((flipped.first_charge->flags & dds::kFlagColdStart) != 0) == !saved_converging);
  CHECK((flipped_log.find("still converging: flag cold_start") != std::string::npos) ==
        !saved_converging);
  CHECK(own_sigma(*flipped.first_charge) < 0.5 * initial_sigma);  // resumed all the same
  stack.daemon().signal(SIGKILL);
  REQUIRE(stack.daemon().wait(5s).has_value());

  // A checkpoint older than estimator.checkpoint_max_age_s (900 s): written two hours ago, it
  // resumes the unit's properties (the charge continues, with its small sigma, and the leak
  // evidence) and re-settles the operating state, converging again.
  double stale_charge = 0.0;
  rewrite_checkpoint(ckpt, [&](runtime::FilterSnapshot& c) {
    c.wall_time_ns -= 7'200'000'000'000;
    c.flags = 0;
    stale_charge = c.x[*plant::create_model("heat_pump_r32", {})->layout().state("charge")];
  });
  reader.take(drain);
  const std::size_t flipped_run_bytes = stack.daemon().err().size();
  stack.start_daemon();
  Seen stale;
  watch(reader, stale, 3s);
  const std::string stale_log = stack.daemon().err().substr(flipped_run_bytes);
  INFO("run from the stale checkpoint:\n" << stale_log);
  REQUIRE(stale.first_charge.has_value());
  REQUIRE(stale.first_leak.has_value());
  CHECK_THAT(stale_log, Catch::Contains("its unit's properties only: it is older than "
                                        "estimator.checkpoint_max_age_s 900 s"));
  CHECK((stale.first_charge->flags & dds::kFlagColdStart) != 0);
  CHECK(stale.first_charge->value == Approx(stale_charge).margin(0.01));
  CHECK(own_sigma(*stale.first_charge) < 0.5 * initial_sigma);
  CHECK(stale.first_leak->hold != dds::LeakHold::kWarmUp);
  stack.daemon().signal(SIGKILL);
  REQUIRE(stack.daemon().wait(5s).has_value());

  // Negative control: the checkpoint removed, the same restart starts over.
  std::filesystem::remove(ckpt);
  reader.take(drain);
  stack.start_daemon();
  Seen cold;
  watch(reader, cold, 3s);
  INFO("third run:\n" << stack.daemon().err());
  REQUIRE(cold.first_charge.has_value());
  REQUIRE(cold.leak.has_value());
  CHECK((cold.first_charge->flags & dds::kFlagColdStart) != 0);
  CHECK(own_sigma(*cold.first_charge) > 0.5 * initial_sigma);
  CHECK(cold.first_leak->hold == dds::LeakHold::kWarmUp);
  CHECK(cold.first_leak->decisions == 0);
  stack.daemon().signal(SIGTERM);
  stack.daemon().wait(10s);
}

// A state the model cannot integrate from (resumed here from a checkpoint whose charge is 0.3 kg
// against pressures and coil masses of 0.5 kg: the model's right-hand side fails at the first
// call). Every prediction fails, keeping x; no update can move it (the output Jacobian fails
// there too). After UnitPipeline::kRestartAfterFailedPredictions (6) in a row the estimator
// restarts from the measured conditions, logged once, flagged, and estimates again.
TEST_CASE("a state the model cannot integrate from: six failed predictions, then a restart",
          "[integration][checkpoint]") {
  StackOptions o = resume_options();
  o.domain_id = 85;
  Stack stack("ckpt-unresolvable", o);
  stack.start_sim();
  dds::Participant participant(loopback_dds(o.domain_id));
  dds::Subscriber reader(participant, "hvac_twin",
                         dds::TopicSet{true, false, false, false, false, false});
  stack.start_daemon();
  const std::string ckpt = stack.path("state/hp1.ckpt");
  REQUIRE(eventually([&] { return std::filesystem::exists(ckpt); }, 30s));
  stack.daemon().signal(SIGKILL);
  REQUIRE(stack.daemon().wait(5s).has_value());
  const auto charge = *plant::create_model("heat_pump_r32", {})->layout().state("charge");
  rewrite_checkpoint(ckpt, [&](runtime::FilterSnapshot& c) { c.x[charge] = 0.3; });

  std::vector<dds::Record> drain;
  reader.take(drain);
  const std::size_t first_run_bytes = stack.daemon().err().size();
  stack.start_daemon();
  const std::string restarted = "predictions in a row failed; the estimator restarts";
  Seen after;
  watch(reader, after, 12s);  // 24 cycles (a restart settles the model: slow under ASan)
  const std::string log = stack.daemon().err().substr(first_run_bytes);
  INFO("run from the unresolvable checkpoint:\n" << log);
  CHECK_THAT(log, Catch::Contains("resumed from checkpoint"));
  CHECK_THAT(log, Catch::Contains("charge 0.3000 kg"));
  // One restart, from the measured conditions, logged once.
  CHECK(log.find(restarted) != std::string::npos);
  CHECK(log.find(restarted) == log.rfind(restarted));
  CHECK_THAT(log, Catch::Contains("(restart 1 since start-up)"));
  // Nothing was published from the unresolvable state (its outputs cannot be evaluated either):
  // the first charge estimate is the restarted filter's, converging again, near the nameplate.
  REQUIRE(after.first_charge.has_value());
  CHECK((after.first_charge->flags & dds::kFlagColdStart) != 0);
  CHECK(after.first_charge->value == Approx(0.5).margin(0.1));
  REQUIRE(after.charge.has_value());
  CHECK(after.charge->quality != dds::EstimateQuality::kNotReady);
  stack.daemon().signal(SIGTERM);
  CHECK(stack.daemon().wait(10s) == 0);
}

TEST_CASE("fsync failing with EIO keeps the daemon running and the previous checkpoint",
          "[integration][checkpoint]") {
  if (!strace_works()) {
    WARN("SKIPPED: strace is missing or cannot trace here (.ci/setup installs it)");
    return;
  }
  StackOptions o = resume_options();
  o.domain_id = kDomain + 1;
  Stack stack("ckpt-eio", o);
  stack.start_sim();
  // Each save is two fsyncs (file, directory): the first save succeeds, every later one fails
  // at the file's fsync. Only fsync is traced (seccomp-bpf): the daemon runs at full speed.
  stack.start_daemon_under({"/usr/bin/strace", "-f", "-qq", "--seccomp-bpf", "-o", "/dev/null",
                            "-E", "ASAN_OPTIONS=detect_leaks=0", "-e", "trace=fsync", "-e",
                            "inject=fsync:error=EIO:when=3+"});
  const bool failed = eventually(
      [&] { return stack.daemon().err().find("checkpoint not saved") != std::string::npos; }, 30s);
  const pid_t daemon = first_child(stack.daemon().pid());
  INFO("daemon stderr:\n" << stack.daemon().err());
  REQUIRE(failed);
  CHECK_THAT(stack.daemon().err(), Catch::Contains("(fsync-file failed: Input/output error)"));
  // Still cycling after the failures: more estimates come, the error is logged once.
  std::this_thread::sleep_for(3s);
  CHECK(stack.daemon().running());
  const std::string log = stack.daemon().err();
  CHECK(log.find("checkpoint not saved") == log.rfind("checkpoint not saved"));
  REQUIRE(daemon > 0);
  ::kill(daemon, SIGTERM);
  REQUIRE(stack.daemon().wait(10s).has_value());

  // The first (good) checkpoint is still there, and the next start resumes from it.
  const std::string ckpt = stack.path("state/hp1.ckpt");
  CHECK(std::filesystem::exists(ckpt));
  CHECK_FALSE(std::filesystem::exists(ckpt + ".tmp"));
  stack.start_daemon();
  CHECK(eventually(
      [&] { return stack.daemon().err().find("resumed from checkpoint") != std::string::npos; },
      20s));
  // It resumes from what is on disk: the checkpoint written before the failures began.
  const auto decoded = read_checkpoint(ckpt);
  REQUIRE(decoded.ok());
  CHECK_THAT(stack.daemon().err(),
             Catch::Contains("(cycle " + std::to_string(decoded.snapshot.cycle) + ","));
  stack.daemon().signal(SIGTERM);
  stack.daemon().wait(10s);
}

TEST_CASE("a disk stalling every fsync for 1.5 s delays no cycle, checkpoints are still saved",
          "[integration][checkpoint]") {
  if (!strace_works()) {
    WARN("SKIPPED: strace is missing or cannot trace here (.ci/setup installs it)");
    return;
  }
  StackOptions o = resume_options();  // a 0.5 s wall cycle, a checkpoint every 4 cycles
  o.domain_id = 118;
  Stack stack("ckpt-stall", o);
  stack.start_sim();
  dds::Participant participant(loopback_dds(o.domain_id));
  // Requests the daemon's deadline (2.5 wall periods, 1.25 s): a save on the cycle thread (two
  // fsyncs, 3 s) would miss it every time.
  dds::Subscriber reader(participant, "hvac_twin",
                         dds::TopicSet{false, false, true, false, false, false},
                         std::chrono::milliseconds(500));
  stack.start_daemon_under({"/usr/bin/strace", "-f", "-qq", "--seccomp-bpf", "-o", "/dev/null",
                            "-E", "ASAN_OPTIONS=detect_leaks=0", "-e", "trace=fsync", "-e",
                            "inject=fsync:delay_enter=1500000"});
  std::vector<dds::Record> got;
  const auto started = std::chrono::steady_clock::now();
  while (got.empty() && std::chrono::steady_clock::now() - started < 30s)
    reader.wait_and_take(100ms, got);
  INFO("daemon stderr:\n" << stack.daemon().err());
  REQUIRE_FALSE(got.empty());
  const std::uint32_t missed_before = reader.status(dds::Topic::kEstimatorHealth).deadline_missed;

  // 10 s: about 20 cycles, 5 checkpoints submitted, 3 saved.
  std::uint64_t first = 0, last = 0, largest_gap = 0;
  const auto end = std::chrono::steady_clock::now() + 10s;
  while (std::chrono::steady_clock::now() < end) {
    got.clear();
    reader.wait_and_take(100ms, got);
    for (const auto& rec : got) {
      const std::uint64_t cycle = std::get<dds::HealthRecord>(rec).cycle;
      if (first == 0) first = cycle;
      if (last != 0) largest_gap = std::max(largest_gap, cycle - last);
      last = cycle;
    }
  }
  INFO("cycles " << first << ".." << last << ", largest gap " << largest_gap);
  CHECK(last - first >= 16);
  // No tick skipped; one is tolerated for a sanitizer build's slow cycle. A save on the cycle
  // thread (3 s) skips 5.
  CHECK(largest_gap <= 2);
  CHECK(reader.status(dds::Topic::kEstimatorHealth).deadline_missed == missed_before);
  CHECK(std::filesystem::exists(stack.path("state/hp1.ckpt")));
  const pid_t daemon = first_child(stack.daemon().pid());
  REQUIRE(daemon > 0);
  ::kill(daemon, SIGTERM);
  REQUIRE(stack.daemon().wait(10s).has_value());
}

TEST_CASE("a clean stop saves the last cycle's state, which the next start resumes from",
          "[integration][checkpoint]") {
  StackOptions o = resume_options();
  o.domain_id = 76;
  o.customize = [base = o.customize](nlohmann::json& c) {
    base(c);
    // No periodic checkpoint within the run: what is on disk after it is the stop's own.
    c["units"][0]["estimator"]["checkpoint_every_cycles"] = 10000;
  };
  Stack stack("ckpt-stop", o);
  stack.start_sim();
  dds::Participant participant(loopback_dds(o.domain_id));
  dds::Subscriber reader(participant, "hvac_twin",
                         dds::TopicSet{false, false, true, false, false, false});  // health
  stack.start_daemon();
  std::uint64_t last_seen = 0;
  std::vector<dds::Record> got;
  const auto end = std::chrono::steady_clock::now() + 20s;
  while (last_seen < 8 && std::chrono::steady_clock::now() < end) {
    got.clear();
    reader.wait_and_take(100ms, got);
    for (const auto& rec : got)
      last_seen = std::get<dds::HealthRecord>(rec).cycle;
  }
  INFO("daemon stderr:\n" << stack.daemon().err());
  REQUIRE(last_seen >= 8);
  const std::string ckpt = stack.path("state/hp1.ckpt");
  CHECK_FALSE(std::filesystem::exists(ckpt));  // no periodic save yet
  stack.daemon().signal(SIGTERM);
  REQUIRE(stack.daemon().wait(10s).has_value());

  // The stop saved the newest cycle: at least the last one published before the signal.
  REQUIRE(std::filesystem::exists(ckpt));
  const auto saved = read_checkpoint(ckpt);
  REQUIRE(saved.ok());
  CHECK(saved.snapshot.cycle >= last_seen);
  CHECK_THAT(stack.daemon().err(),
             Catch::Contains("checkpoint of cycle " + std::to_string(saved.snapshot.cycle) +
                             " handed to its writer on stop"));
  const std::size_t first_run_bytes = stack.daemon().err().size();
  stack.start_daemon();
  CHECK(eventually(
      [&] {
        return stack.daemon().err().find("resumed from checkpoint", first_run_bytes) !=
               std::string::npos;
      },
      20s));
  CHECK_THAT(stack.daemon().err().substr(first_run_bytes),
             Catch::Contains("(cycle " + std::to_string(saved.snapshot.cycle) + ","));
  stack.daemon().signal(SIGTERM);
  stack.daemon().wait(10s);
}
