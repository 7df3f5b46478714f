// Recorder::submit() runs in the estimator's cycle: it must not allocate. Counts heap allocations
// by replacing operator new, so an executable of its own.
#include <catch2/catch.hpp>

#include "daemon/recording/recorder.hpp"
#include "tests/support/alloc_counter.hpp"
#include "tests/support/scratch_dir.hpp"
#include "tests/unit/recording/recording_test_support.hpp"

using namespace hvac_twin;

TEST_CASE("submitting a cycle to the recorder makes no heap allocation", "[recording][alloc]") {
  test::ScratchDir dir("recorder-alloc");
  recording::Recorder r(dir.path().string(), test::recording_header(13), 256 * 1024,
                        test::quiet_logger());
  const auto c = test::make_cycle(1, 13);
  r.submit(1, 1, c.timestamp_ns, c.connected, c.samples, c.now_ns);
  // Counted on this thread only: the writer thread allocates as it opens files, off the cycle.
  const long before = test::allocations_on_this_thread();
  // More than the ring holds: the submits that find it full (a slow disk) take part too.
  for (std::uint64_t k = 2; k <= 400; ++k)
    r.submit(k, 1, c.timestamp_ns + static_cast<std::int64_t>(k), k % 2 == 0, c.samples, c.now_ns);
  const long during = test::allocations_on_this_thread() - before;
  CHECK(during == 0);
}
