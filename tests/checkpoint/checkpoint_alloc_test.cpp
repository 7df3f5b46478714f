// save() allocates nothing once the store is built: the daemon calls it from its cycle.
#include <atomic>
#include <catch2/catch.hpp>
#include <cstdlib>
#include <new>

#include "daemon/runtime/checkpoint_store.hpp"
#include "tests/checkpoint/checkpoint_fixture.hpp"

namespace {
std::atomic<long> g_allocations{0};
std::atomic<bool> g_counting{false};
}  // namespace

// Counting replacements of the global allocation functions (this executable only), left out
// under AddressSanitizer, which brings its own allocator (as in ekf_alloc_test.cpp).
#if defined(__SANITIZE_ADDRESS__)
#define HVAC_TWIN_COUNT_ALLOCATIONS 0
#else
#define HVAC_TWIN_COUNT_ALLOCATIONS 1
void* operator new(std::size_t size) {
  if (g_counting.load(std::memory_order_relaxed)) g_allocations.fetch_add(1);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
// GCC flags free() of memory from a replaced operator new as mismatched; here it is the match.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
#pragma GCC diagnostic pop
#endif

using namespace hvac_twin;

TEST_CASE("saving a checkpoint makes no heap allocation", "[checkpoint][alloc]") {
  test::TempDir dir;
  runtime::CheckpointStore store(dir.str(), "state.ckpt", test::checkpoint_expectation(16));
  runtime::FilterSnapshot snapshot;
  test::fill_snapshot(snapshot, 1, 16);
  REQUIRE(store.save(snapshot).ok());
  g_counting = true;
  bool ok = true;
  for (std::uint64_t cycle = 2; cycle < 50; ++cycle) {
    test::fill_snapshot(snapshot, cycle, 16);  // refilled in place, as the daemon does
    ok = store.save(snapshot).ok() && ok;
  }
  g_counting = false;
  CHECK(ok);
  if (!HVAC_TWIN_COUNT_ALLOCATIONS) {
    WARN("allocation count SKIPPED under AddressSanitizer (operator new is not replaced)");
    return;
  }
  CHECK(g_allocations.load() == 0);
}
