// The checkpoint writer thread (daemon/runtime/checkpoint_writer.hpp): the newest snapshot is the
// one saved, nothing submitted is lost at stop, and failures are logged once per episode.
#include "daemon/runtime/checkpoint_writer.hpp"

#include <spdlog/sinks/ostream_sink.h>

#include <catch2/catch.hpp>
#include <chrono>
#include <filesystem>
#include <sstream>
#include <thread>

#include "daemon/runtime/checkpoint_store.hpp"
#include "tests/checkpoint/checkpoint_fixture.hpp"

using namespace hvac_twin;
using namespace std::chrono_literals;

namespace {

constexpr std::size_t kStates = 6;
constexpr std::int64_t kNow = 1'700'000'000'000'000'000;

std::shared_ptr<spdlog::logger> logger_to(std::ostringstream& out) {
  return std::make_shared<spdlog::logger>("test",
                                          std::make_shared<spdlog::sinks::ostream_sink_mt>(out));
}

// Waits (up to 10 s) until the writer has finished `n` saves, good or failed.
bool wait_for_saves(const runtime::CheckpointWriter& w, std::uint64_t n) {
  const auto end = std::chrono::steady_clock::now() + 10s;
  while (std::chrono::steady_clock::now() < end) {
    const auto s = w.stats();
    if (s.saved + s.failed >= n) return true;
    std::this_thread::sleep_for(1ms);
  }
  return false;
}

std::size_t count(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (auto at = text.find(what); at != std::string::npos; at = text.find(what, at + 1))
    ++n;
  return n;
}

}  // namespace

TEST_CASE("the checkpoint writer saves the newest snapshot and, stopped, what still waits",
          "[checkpoint][writer]") {
  test::TempDir dir;
  runtime::CheckpointStore store(dir.str(), "hp1.ckpt", test::checkpoint_expectation(kStates));
  std::ostringstream log;
  constexpr std::uint64_t kSubmitted = 200;
  {
    runtime::FilterSnapshot s = test::make_snapshot(1, kStates);
    runtime::CheckpointWriter writer(store, s, logger_to(log), "hp1");
    for (std::uint64_t cycle = 1; cycle <= kSubmitted; ++cycle) {
      test::fill_snapshot(s, cycle, kStates);
      writer.submit(s);  // faster than two fsyncs each: most are superseded
    }
  }  // the destructor saves the last one if it still waits
  const runtime::LoadResult r = store.load(kNow);
  REQUIRE(r.outcome == runtime::LoadOutcome::kLoaded);
  CHECK(r.snapshot.cycle == kSubmitted);
  CHECK(test::is_snapshot_of_its_cycle(r.snapshot));
  CHECK(log.str().empty());
}

TEST_CASE("the checkpoint writer counts every snapshot as saved or superseded",
          "[checkpoint][writer]") {
  test::TempDir dir;
  runtime::CheckpointStore store(dir.str(), "hp1.ckpt", test::checkpoint_expectation(kStates));
  std::ostringstream log;
  runtime::FilterSnapshot s = test::make_snapshot(1, kStates);
  runtime::CheckpointWriter writer(store, s, logger_to(log), "hp1");
  for (std::uint64_t cycle = 1; cycle <= 50; ++cycle) {
    test::fill_snapshot(s, cycle, kStates);
    writer.submit(s);
  }
  // Everything not superseded is saved eventually.
  const auto end = std::chrono::steady_clock::now() + 10s;
  while (std::chrono::steady_clock::now() < end) {
    const auto st = writer.stats();
    if (st.saved + st.superseded == 50) break;
    std::this_thread::sleep_for(1ms);
  }
  const auto st = writer.stats();
  CHECK(st.saved + st.superseded == 50);
  CHECK(st.saved >= 1);
  CHECK(st.failed == 0);
}

TEST_CASE("a failing checkpoint save is logged once per episode, and the recovery once",
          "[checkpoint][writer]") {
  test::TempDir dir;
  const std::filesystem::path state = dir.path() / "state";
  std::filesystem::create_directory(state);
  runtime::CheckpointStore store(state.string(), "hp1.ckpt", test::checkpoint_expectation(kStates));
  std::ostringstream log;
  runtime::FilterSnapshot s = test::make_snapshot(1, kStates);
  runtime::CheckpointWriter writer(store, s, logger_to(log), "hp1");
  std::uint64_t done = 0;
  const auto save = [&](std::uint64_t cycle) {
    test::fill_snapshot(s, cycle, kStates);
    writer.submit(s);
    REQUIRE(wait_for_saves(writer, ++done));  // one at a time: none superseded
  };
  save(1);
  std::filesystem::remove_all(state);  // the directory gone: open() fails with ENOENT
  save(2);
  save(3);
  save(4);
  std::filesystem::create_directory(state);
  save(5);
  save(6);
  const auto st = writer.stats();
  CHECK(st.saved == 3);
  CHECK(st.failed == 3);
  CHECK(st.superseded == 0);
  const std::string text = log.str();
  INFO(text);
  CHECK(count(text, "unit hp1: checkpoint not saved (open failed: No such file or directory)") ==
        1);
  CHECK(count(text, "checkpoint not saved") == 1);
  CHECK(count(text, "unit hp1: checkpoints are saved again") == 1);
  const runtime::LoadResult r = store.load(kNow);
  REQUIRE(r.outcome == runtime::LoadOutcome::kLoaded);
  CHECK(r.snapshot.cycle == 6);
}
