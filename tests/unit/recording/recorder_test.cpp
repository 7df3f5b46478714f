// The recorder thread (daemon/recording/recorder.hpp): rotation through files within the budget,
// the newest records kept without a gap, a new file per start, the queue drained at destruction.
#include "daemon/recording/recorder.hpp"

#include <spdlog/sinks/ostream_sink.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <chrono>
#include <filesystem>
#include <map>
#include <numeric>
#include <sstream>
#include <thread>

#include "daemon/recording/recording_reader.hpp"
#include "tests/support/scratch_dir.hpp"
#include "tests/unit/recording/recording_test_support.hpp"

using namespace hvac_twin;
using namespace std::chrono_literals;
using recording::Recorder;

namespace {

constexpr std::size_t kPoints = 13;
// Files of kMinFileBytes (64 KiB). Not a whole number of files: whether the budget leaves room
// for the file being written decides how many older files stay (3, not 4).
constexpr std::uint64_t kBudget = 300 * 1024;

void submit(Recorder& r, std::uint64_t cycle) {
  const auto c = test::make_cycle(cycle, kPoints);
  r.submit(c.cycle, c.ticks_since_last, c.timestamp_ns, c.connected, c.samples, c.now_ns);
}

std::uint64_t handled(const Recorder& r) {
  const auto s = r.stats();
  return s.recorded + s.dropped + s.failed;
}

// Waits (up to 10 s) until the recorder has dealt with `submitted` records.
bool wait_for(const Recorder& r, std::uint64_t submitted) {
  const auto end = std::chrono::steady_clock::now() + 10s;
  while (handled(r) < submitted) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(1ms);
  }
  return true;
}

// Submits cycles [first, last], never more than 200 ahead of the writer: none is dropped.
void submit_paced(Recorder& r, std::uint64_t first, std::uint64_t last) {
  const std::uint64_t before = handled(r);
  for (std::uint64_t k = first; k <= last; ++k) {
    const auto end = std::chrono::steady_clock::now() + 10s;
    while (before + (k - first) - handled(r) >= 200 && std::chrono::steady_clock::now() < end)
      std::this_thread::sleep_for(50us);
    submit(r, k);
  }
}

struct RecordingFile {
  std::string path;
  std::uint64_t size = 0;
  std::uint64_t sequence = 0;  // the header's
  std::vector<std::uint64_t> cycles;
};

// The unit's files, oldest first, each read to its end: a header of the recorder's unit and
// whole records, no torn tail.
std::vector<RecordingFile> read_unit(const test::ScratchDir& dir, const std::string& unit,
                                     const recording::RecordingHeader& want) {
  std::vector<RecordingFile> out;
  for (const auto& path : recording::unit_recordings(dir.path().string(), unit)) {
    INFO(path);
    recording::RecordingReader reader(path);
    CHECK(reader.header().unit == unit);
    CHECK(reader.header().site == want.site);
    CHECK(reader.header().run_ns == want.run_ns);
    CHECK(reader.header().points.size() == want.points.size());
    RecordingFile f{.path = path,
                    .size = std::filesystem::file_size(path),
                    .sequence = reader.header().sequence};
    // The name's sequence number is the header's.
    char name[64];
    std::snprintf(name, sizeof name, "%s.%08llu.htrec", unit.c_str(),
                  static_cast<unsigned long long>(f.sequence));
    CHECK(std::filesystem::path(path).filename() == name);
    recording::RecordedCycle c;
    while (reader.next(c)) {
      CHECK(c.samples.size() == kPoints);
      f.cycles.push_back(c.cycle);
    }
    CHECK_FALSE(reader.torn_tail());
    out.push_back(std::move(f));
  }
  return out;
}

std::vector<std::uint64_t> all_cycles(const std::vector<RecordingFile>& files) {
  std::vector<std::uint64_t> out;
  for (const auto& f : files)
    out.insert(out.end(), f.cycles.begin(), f.cycles.end());
  return out;
}

}  // namespace

TEST_CASE(
    "the recorder rotates files and deletes the oldest within its budget, losing no record "
    "between the files it keeps",
    "[recording][recorder]") {
  test::ScratchDir dir("recorder-budget");
  const auto header = test::recording_header(kPoints);
  constexpr std::uint64_t kCycles = 3000;  // about 13 files of 64 KiB
  recording::RecorderStats stats;
  {
    Recorder r(dir.path().string(), header, kBudget, test::quiet_logger());
    CHECK(r.directory() == dir.path().string());
    submit_paced(r, 1, kCycles);
    REQUIRE(wait_for(r, kCycles));
    stats = r.stats();
  }
  CHECK(stats.recorded == kCycles);
  CHECK(stats.dropped == 0);
  CHECK(stats.failed == 0);
  CHECK(stats.files_deleted > 0);

  const auto files = read_unit(dir, header.unit, header);
  REQUIRE(files.size() >= 2);
  // The files kept are the newest, numbered without a gap after the ones deleted.
  CHECK(files.front().sequence == stats.files_deleted + 1);
  for (std::size_t i = 1; i < files.size(); ++i)
    CHECK(files[i].sequence == files[i - 1].sequence + 1);
  // Every record from the oldest kept to the last submitted, in order, across the files.
  const auto cycles = all_cycles(files);
  REQUIRE(!cycles.empty());
  CHECK(cycles.back() == kCycles);
  for (std::size_t i = 1; i < cycles.size(); ++i)
    REQUIRE(cycles[i] == cycles[i - 1] + 1);

  // enforce_budget() runs when a file is opened and counts the new file at its full size: the
  // older files plus a whole file fit the budget, so the unit never exceeds it as that file fills.
  const std::uint64_t limit = std::max(kBudget / 8, Recorder::kMinFileBytes);
  std::uint64_t older = 0, smallest = limit;
  for (std::size_t i = 0; i + 1 < files.size(); ++i) {
    older += files[i].size;
    smallest = std::min(smallest, files[i].size);
  }
  for (const auto& f : files)
    CHECK(f.size <= limit);
  CHECK(older + limit <= kBudget);
  CHECK(older + files.back().size <= kBudget);
  // ... and it deletes no more than that: one more full file would not have fitted.
  CHECK(older + smallest + limit > kBudget);
  // A full file holds as many records as fit: the next one would have crossed the limit.
  CHECK(files.front().size + recording::record_size(kPoints) > limit);
}

TEST_CASE("a budget below one file keeps only the file being written", "[recording][recorder]") {
  test::ScratchDir dir("recorder-small");
  const auto header = test::recording_header(kPoints);
  recording::RecorderStats stats;
  {
    Recorder r(dir.path().string(), header, 10 * 1024, test::quiet_logger());
    submit_paced(r, 1, 600);  // three files of 64 KiB
    REQUIRE(wait_for(r, 600));
    stats = r.stats();
  }
  CHECK(stats.recorded == 600);
  CHECK(stats.files_deleted == 2);
  const auto files = read_unit(dir, header.unit, header);
  REQUIRE(files.size() == 1);
  CHECK(files[0].sequence == 3);
  CHECK(files[0].size <= Recorder::kMinFileBytes);
  CHECK(files[0].cycles.back() == 600);
}

TEST_CASE("the recorder writes everything queued before its destructor returns",
          "[recording][recorder]") {
  test::ScratchDir dir("recorder-drain");
  const auto header = test::recording_header(kPoints);
  {
    Recorder r(dir.path().string(), header, kBudget, test::quiet_logger());
    // Fewer than the ring holds: none can be dropped, all are still queued or being written.
    for (std::uint64_t k = 1; k <= 200; ++k)
      submit(r, k);
  }
  const auto files = read_unit(dir, header.unit, header);
  REQUIRE(files.size() == 1);
  CHECK(files[0].sequence == 1);
  std::vector<std::uint64_t> want(200);
  std::iota(want.begin(), want.end(), 1);
  CHECK(files[0].cycles == want);

  // Submitted values are the ones read back.
  recording::RecordingReader reader(files[0].path);
  recording::RecordedCycle got;
  REQUIRE(reader.next(got));
  const auto c = test::make_cycle(1, kPoints);
  CHECK(got.timestamp_ns == c.timestamp_ns);
  CHECK(got.connected == c.connected);
  for (std::size_t i = 0; i < kPoints; ++i) {
    CHECK(got.samples[i].value == c.samples[i].value);
    CHECK(got.samples[i].quality == c.samples[i].quality);
  }
}

TEST_CASE("a recorder that cannot keep up drops and counts records, never reorders them",
          "[recording][recorder]") {
  test::ScratchDir dir("recorder-burst");
  const auto header = test::recording_header(kPoints);
  std::ostringstream log_text;
  auto log = std::make_shared<spdlog::logger>(
      "recorder-test", std::make_shared<spdlog::sinks::ostream_sink_mt>(log_text));
  constexpr std::uint64_t kCycles = 3000;
  recording::RecorderStats stats;
  {
    Recorder r(dir.path().string(), header, kBudget, log);
    for (std::uint64_t k = 1; k <= kCycles; ++k)
      submit(r, k);
    REQUIRE(wait_for(r, kCycles));
    stats = r.stats();
  }
  CHECK(stats.recorded + stats.dropped == kCycles);
  CHECK(stats.failed == 0);
  if (stats.dropped > 0) CHECK_THAT(log_text.str(), Catch::Contains("not recorded"));
  const auto cycles = all_cycles(read_unit(dir, header.unit, header));
  REQUIRE(!cycles.empty());
  CHECK(cycles.size() <= stats.recorded);
  CHECK(std::is_sorted(cycles.begin(), cycles.end()));
  CHECK(std::adjacent_find(cycles.begin(), cycles.end()) == cycles.end());
}

TEST_CASE("a second recorder on the directory starts a new file, leaving the old ones as they were",
          "[recording][recorder]") {
  test::ScratchDir dir("recorder-restart");
  const auto header = test::recording_header(kPoints);
  {
    Recorder r(dir.path().string(), header, kBudget, test::quiet_logger());
    submit_paced(r, 1, 600);  // three files, the last one partly filled
    REQUIRE(wait_for(r, 600));
  }
  const auto before = read_unit(dir, header.unit, header);
  REQUIRE(before.size() == 3);
  std::map<std::string, std::vector<std::byte>> old_bytes;
  for (const auto& f : before)
    old_bytes[f.path] = test::read_bytes(f.path);

  recording::RecorderStats stats;
  {
    Recorder r(dir.path().string(), header, kBudget, test::quiet_logger());
    submit_paced(r, 601, 605);
    REQUIRE(wait_for(r, 5));
    stats = r.stats();
  }
  CHECK(stats.recorded == 5);
  CHECK(stats.files_deleted == 0);  // three files and a new one fit the budget
  const auto after = read_unit(dir, header.unit, header);
  REQUIRE(after.size() == 4);
  for (const auto& [path, bytes] : old_bytes)
    CHECK(test::read_bytes(path) == bytes);
  CHECK(after.back().sequence == before.back().sequence + 1);
  CHECK(after.back().cycles == std::vector<std::uint64_t>{601, 602, 603, 604, 605});

  // Another unit in the same directory numbers its files on its own and leaves these alone.
  const auto other = test::recording_header(kPoints, "ahu-2");
  {
    Recorder r(dir.path().string(), other, 10 * 1024, test::quiet_logger());
    submit(r, 1);
  }
  const auto other_files = read_unit(dir, "ahu-2", other);
  REQUIRE(other_files.size() == 1);
  CHECK(other_files[0].sequence == 1);
  CHECK(read_unit(dir, header.unit, header).size() == 4);
}

TEST_CASE("a recorder whose directory cannot be created throws, naming it",
          "[recording][recorder]") {
  test::ScratchDir dir("recorder-nodir");
  test::write_bytes(dir / "file", {});
  const std::string path = dir / "file/recordings";
  CHECK_THROWS_WITH(Recorder(path, test::recording_header(kPoints), kBudget, test::quiet_logger()),
                    Catch::Contains(path) && Catch::Contains("cannot be created"));
}
