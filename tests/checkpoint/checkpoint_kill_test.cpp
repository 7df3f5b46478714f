// kill -9 at random moments: a writer process saves checkpoints in a tight loop and is killed
// a random 0-30 ms after its first save began; then the checkpoint is loaded as a restarted daemon
// would. The atomic store must yield a whole checkpoint, never older than the previous trial's, in
// every trial; the naive in-place writer (the negative control) must fail the same harness at least
// once, which shows that the harness can fail.
//
// What this proves and what it does not: SIGKILL ends the process, not the kernel, so the page
// cache survives and every write() the writer completed stays visible. The test therefore
// checks the ordering of write, rename and cleanup against a process crash at any instant
// (interrupted writes, a stray temporary, a reader seeing a half-written file). It says nothing
// about a power cut, where unsynced pages are lost: that is the fsync argument in
// daemon/runtime/checkpoint_store.hpp, and the fsync calls' failures are tested by
// checkpoint_fault_test.cpp.
//
// The delays come from a seeded generator (HVAC_TWIN_CKPT_SEED, default below), printed, and run
// from the writer's first visible save, not from its exec: on a loaded machine (or under the
// sanitizers) a writer can need more than the whole delay range to start, and every kill then
// landed before its first save (seen once under ASan with the machine busy: 200 of 200 trials
// killed at start-up, so the negative control found nothing). The kill instants still depend on
// scheduling, so a run is repeatable in distribution only.
#include <signal.h>
#include <sys/stat.h>

#include <array>
#include <catch2/catch.hpp>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <thread>

#include "daemon/runtime/checkpoint_store.hpp"
#include "tests/checkpoint/checkpoint_fixture.hpp"
#include "tests/checkpoint/child_process.hpp"

using namespace hvac_twin;
using runtime::LoadOutcome;

namespace {

constexpr int kTrials = 200;
constexpr std::size_t kStates = 64;  // a 33 kB checkpoint

struct Tally {
  int trials = 0, whole = 0, missing = 0, corrupt = 0, went_back = 0;
  int interrupted = 0;  // killed inside a save: its temporary was left for load() to delete
  [[nodiscard]] int bad() const { return missing + corrupt + went_back; }
};

std::uint32_t seed() {
  const char* env = std::getenv("HVAC_TWIN_CKPT_SEED");
  return env != nullptr ? static_cast<std::uint32_t>(std::strtoul(env, nullptr, 10)) : 20240611U;
}

std::vector<std::string> writer_args(const test::TempDir& dir, bool naive, std::uint64_t start,
                                     std::uint64_t count) {
  std::vector<std::string> a{HVAC_TWIN_CKPT_WRITER,
                             dir.str(),
                             "--start",
                             std::to_string(start),
                             "--count",
                             std::to_string(count),
                             "--states",
                             std::to_string(kStates)};
  if (naive) a.emplace_back("--naive");
  return a;
}

// What the checkpoint file is now (which inode, when last changed, how long), or all zero.
std::array<long long, 4> file_state(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return {};
  return {static_cast<long long>(st.st_ino), static_cast<long long>(st.st_mtim.tv_sec),
          static_cast<long long>(st.st_mtim.tv_nsec), static_cast<long long>(st.st_size)};
}

// Waits (up to 20 s) until the writer has begun its first save: the checkpoint file changed
// (renamed over, or rewritten in place) or the atomic writer's temporary exists.
bool wait_for_first_save(const std::string& file, const std::array<long long, 4>& before) {
  const std::string tmp = file + ".tmp";
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (std::chrono::steady_clock::now() < until) {
    struct stat st {};
    if (file_state(file) != before || ::stat(tmp.c_str(), &st) == 0) return true;
    std::this_thread::sleep_for(std::chrono::microseconds(50));
  }
  return false;
}

Tally kill_trials(bool naive, std::uint32_t seed_value) {
  test::TempDir dir;
  runtime::CheckpointStore store(dir.str(), "state.ckpt", test::checkpoint_expectation(kStates));
  std::mt19937 rng(seed_value);
  std::uniform_int_distribution<int> delay_us(0, 30'000);
  std::uint64_t last = 1;
  // One complete save first, so that every trial has a previous checkpoint to keep.
  REQUIRE(test::run_child(writer_args(dir, naive, last, 1)).exited_ok());
  const std::string file = dir.str() + "/state.ckpt";
  Tally t;
  for (int trial = 0; trial < kTrials; ++trial) {
    const auto before = file_state(file);
    const pid_t pid = test::spawn_child(writer_args(dir, naive, last + 1, 0));
    REQUIRE(pid > 0);
    if (!wait_for_first_save(file, before)) {
      ::kill(pid, SIGKILL);
      test::wait_child(pid);
      FAIL("the writer did not begin a save within 20 s");
    }
    std::this_thread::sleep_for(std::chrono::microseconds(delay_us(rng)));
    ::kill(pid, SIGKILL);
    const int status = test::wait_child(pid);
    REQUIRE(WIFSIGNALED(status));
    ++t.trials;
    // What a restarted daemon does: load (which also deletes a stray temporary).
    const auto r = store.load(0);
    t.interrupted += r.removed_stray_tmp ? 1 : 0;
    if (r.outcome == LoadOutcome::kLoaded && test::is_snapshot_of_its_cycle(r.snapshot) &&
        r.snapshot.cycle >= last) {
      ++t.whole;
      last = r.snapshot.cycle;
      continue;
    }
    if (r.outcome == LoadOutcome::kNoCheckpoint) {
      ++t.missing;
    } else if (r.outcome == LoadOutcome::kLoaded) {
      ++t.went_back;
    } else {
      ++t.corrupt;
    }
    UNSCOPED_INFO("trial " << trial << ": " << r.describe());
    // Start the next trial from a good checkpoint again, so that each failure is its own.
    REQUIRE(test::run_child(writer_args(dir, naive, ++last, 1)).exited_ok());
  }
  std::printf(
      "kill -9 %s writer: %d trials, %d whole, %d missing, %d corrupt, %d older than before, "
      "%d killed inside a save (seed %u, HVAC_TWIN_CKPT_SEED to change); last cycle %llu\n",
      naive ? "naive" : "atomic", t.trials, t.whole, t.missing, t.corrupt, t.went_back,
      t.interrupted, seed_value, static_cast<unsigned long long>(last));
  return t;
}

}  // namespace

TEST_CASE("kill -9 at random moments never leaves a missing or corrupt checkpoint",
          "[checkpoint][kill]") {
  const Tally t = kill_trials(false, seed());
  CHECK(t.trials == kTrials);
  CHECK(t.bad() == 0);
  // Not vacuous: some kills landed between the temporary's creation and the rename.
  CHECK(t.interrupted > 0);
}

TEST_CASE("negative control: a naive in-place writer fails the same kill -9 test",
          "[checkpoint][kill]") {
  const Tally t = kill_trials(true, seed());
  CHECK(t.trials == kTrials);
  CHECK(t.bad() > 0);
}
