// The checkpoint store on a real directory: save and load, the cold starts (no file, or a file
// rejected and moved aside), stray temporaries, and save() failures that keep the previous
// checkpoint and throw nothing.
#include "daemon/runtime/checkpoint_store.hpp"

#include <sys/stat.h>

#include <catch2/catch.hpp>
#include <filesystem>

#include "tests/checkpoint/checkpoint_fixture.hpp"

using namespace hvac_twin;
using runtime::CheckpointError;
using runtime::LoadOutcome;
using runtime::SaveStep;

namespace fs = std::filesystem;

namespace {

constexpr std::size_t kStates = 4;
constexpr std::int64_t kNow = 1'700'000'000'000'000'000;

runtime::CheckpointStore make_store(const test::TempDir& dir, std::int64_t max_age_ns = 0) {
  auto e = test::checkpoint_expectation(kStates);
  e.max_age_ns = max_age_ns;
  return runtime::CheckpointStore(dir.str(), "state.ckpt", e);
}

}  // namespace

TEST_CASE("a saved checkpoint loads back whole", "[checkpoint][store]") {
  test::TempDir dir;
  auto store = make_store(dir);
  REQUIRE(store.save(test::make_snapshot(11, kStates)).ok());
  REQUIRE(store.save(test::make_snapshot(12, kStates)).ok());
  CHECK_FALSE(fs::exists(store.tmp_path()));
  struct stat st {};
  REQUIRE(::stat(store.path().c_str(), &st) == 0);
  CHECK((st.st_mode & 0777) == 0600);

  const auto r = store.load(kNow);
  INFO(r.describe());
  REQUIRE(r.outcome == LoadOutcome::kLoaded);
  CHECK_FALSE(r.cold_start());
  CHECK(r.snapshot.cycle == 12);
  CHECK(test::is_snapshot_of_its_cycle(r.snapshot));
  CHECK(fs::exists(store.path()));  // loading leaves a good checkpoint where it is
}

TEST_CASE("no checkpoint is a cold start, not an error", "[checkpoint][store]") {
  test::TempDir dir;
  const auto r = make_store(dir).load(kNow);
  CHECK(r.outcome == LoadOutcome::kNoCheckpoint);
  CHECK(r.cold_start());
  CHECK_FALSE(r.moved_aside);
}

TEST_CASE("load deletes the temporary of an interrupted save", "[checkpoint][store]") {
  test::TempDir dir;
  auto store = make_store(dir);
  REQUIRE(store.save(test::make_snapshot(5, kStates)).ok());
  auto half = test::encode(test::make_snapshot(6, kStates));
  half.resize(half.size() / 2);
  test::write_bytes(store.tmp_path(), half);
  const auto r = store.load(kNow);
  CHECK(r.removed_stray_tmp);
  CHECK_FALSE(fs::exists(store.tmp_path()));
  REQUIRE(r.outcome == LoadOutcome::kLoaded);
  CHECK(r.snapshot.cycle == 5);
}

TEST_CASE("a bad checkpoint is rejected with its reason and moved aside", "[checkpoint][store]") {
  const auto good = test::encode(test::make_snapshot(8, kStates));
  auto truncated = good;
  truncated.resize(good.size() - 9);
  auto corrupted = good;
  corrupted[good.size() / 2] ^= std::byte{0x10};
  auto version = good;
  version[8] = std::byte{2};
  auto nan = test::make_snapshot(8, kStates);
  nan.P[5] = std::numeric_limits<double>::quiet_NaN();
  auto other = test::make_snapshot(8, kStates);
  other.unit_id = "hp9";
  struct Case {
    const char* name;
    std::vector<std::byte> bytes;
    CheckpointError error;
    std::int64_t max_age_ns = 0;
  };
  const Case cases[] = {
      {"empty", {}, CheckpointError::kTruncated},
      {"truncated", truncated, CheckpointError::kTruncated},
      {"bad checksum", corrupted, CheckpointError::kBadChecksum},
      {"wrong version", version, CheckpointError::kWrongVersion},
      {"NaN in P", test::encode(nan), CheckpointError::kImplausible},
      {"another unit", test::encode(other), CheckpointError::kWrongModel},
      {"too old", good, CheckpointError::kStale, 3'600'000'000'000},
  };
  for (const Case& c : cases) {
    test::TempDir dir;
    auto store = make_store(dir, c.max_age_ns);
    test::write_bytes(store.path(), c.bytes);
    const std::int64_t now = kNow + 86'400'000'000'000;  // a day after the fixture's cycles
    const auto r = store.load(now);
    INFO(c.name << ": " << r.describe());
    CHECK(r.outcome == LoadOutcome::kRejected);
    CHECK(r.cold_start());
    CHECK(r.reason.error == c.error);
    CHECK_FALSE(r.reason.message.empty());
    CHECK(r.moved_aside);
    CHECK_FALSE(fs::exists(store.path()));
    CHECK(test::read_bytes(store.rejected_path()) == c.bytes);
    // The daemon then runs on and its next checkpoint is good again.
    REQUIRE(store.save(test::make_snapshot(9, kStates)).ok());
    CHECK(store.load(kNow).snapshot.cycle == 9);
  }
}

TEST_CASE("a file far larger than any checkpoint is rejected unread", "[checkpoint][store]") {
  test::TempDir dir;
  auto store = make_store(dir);
  {
    std::ofstream big(store.path(), std::ios::binary);
    big.seekp(64L << 20);
    big.put('x');
  }
  const auto r = store.load(kNow);
  CHECK(r.outcome == LoadOutcome::kRejected);
  CHECK(r.reason.error == CheckpointError::kImplausible);
  CHECK(r.moved_aside);
}

TEST_CASE("failed saves keep the previous checkpoint, leave no temporary, never throw",
          "[checkpoint][store]") {
  test::TempDir dir;
  auto store = make_store(dir);
  REQUIRE(store.save(test::make_snapshot(20, kStates)).ok());

  SECTION("a snapshot of another size fails to encode") {
    const auto s = store.save(test::make_snapshot(21, kStates + 1));
    CHECK(s.failed_step == SaveStep::kEncode);
    CHECK(s.error == EINVAL);
  }
  SECTION("the checkpoint's name taken by a directory fails the rename") {
    fs::remove(store.path());
    fs::create_directories(fs::path(store.path()) / "occupied");
    const auto s = store.save(test::make_snapshot(21, kStates));
    CHECK(s.failed_step == SaveStep::kRename);
    CHECK((s.error == EISDIR || s.error == ENOTEMPTY || s.error == EEXIST));
    CHECK_FALSE(fs::exists(store.tmp_path()));
    fs::remove_all(store.path());
    REQUIRE(store.save(test::make_snapshot(20, kStates)).ok());
  }
  SECTION("the temporary's name taken by a directory fails the open") {
    fs::create_directories(store.tmp_path());
    const auto s = store.save(test::make_snapshot(21, kStates));
    CHECK(s.failed_step == SaveStep::kOpen);
    CHECK(s.error == EISDIR);
    fs::remove(store.tmp_path());
  }
  const auto r = store.load(kNow);
  REQUIRE(r.outcome == LoadOutcome::kLoaded);
  CHECK(r.snapshot.cycle == 20);
  CHECK_FALSE(fs::exists(store.tmp_path()));
}

TEST_CASE("saving into a missing directory reports the open", "[checkpoint][store]") {
  test::TempDir dir;
  runtime::CheckpointStore store(dir.str() + "/missing", "state.ckpt",
                                 test::checkpoint_expectation(kStates));
  const auto s = store.save(test::make_snapshot(1, kStates));
  CHECK(s.failed_step == SaveStep::kOpen);
  CHECK(s.error == ENOENT);
  CHECK(store.load(kNow).outcome == LoadOutcome::kNoCheckpoint);
}
