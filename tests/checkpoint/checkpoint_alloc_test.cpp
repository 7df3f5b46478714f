// save() allocates nothing once the store is built: the daemon calls it from its cycle.
#include <catch2/catch.hpp>

#include "daemon/runtime/checkpoint_store.hpp"
#include "tests/checkpoint/checkpoint_fixture.hpp"
#include "tests/support/alloc_counter.hpp"

using namespace hvac_twin;

TEST_CASE("saving a checkpoint makes no heap allocation", "[checkpoint][alloc]") {
  test::TempDir dir;
  runtime::CheckpointStore store(dir.str(), "state.ckpt", test::checkpoint_expectation(16));
  runtime::FilterSnapshot snapshot;
  test::fill_snapshot(snapshot, 1, 16);
  REQUIRE(store.save(snapshot).ok());
  const test::AllocationScope scope;
  bool ok = true;
  for (std::uint64_t cycle = 2; cycle < 50; ++cycle) {
    test::fill_snapshot(snapshot, cycle, 16);  // refilled in place, as the daemon does
    ok = store.save(snapshot).ok() && ok;
  }
  CHECK(ok);
  CHECK(scope.count() == 0);
}
