// Counts heap allocations through the replaceable global operator new, for the tests that check
// a periodic path allocates nothing. Linking hvac_twin::test_alloc_counter into a test executable
// replaces every variant of operator new and delete there (malloc and free underneath, so
// AddressSanitizer sees matching pairs), so such a test is an executable of its own.
//
// Counted in the whole process, per thread, and for one thread a test names (a poller thread).
// Thread-safe; the counting functions never allocate.
#pragma once

#include <thread>

namespace hvac_twin::test {

// Allocations made in the process since it started (every thread: a filter's workers too; Catch2
// starts none, and Cyclone DDS and libmodbus allocate with malloc, not operator new).
long allocations_in_process();

// Allocations made on the calling thread since it started.
long allocations_on_this_thread();

// From now on, allocations made on `thread` are also counted in watched_allocations(), which is
// reset to zero.
void watch_allocations_of(std::thread::id thread);
long watched_allocations();

// The allocations made in the process while one is alive.
class AllocationScope {
 public:
  AllocationScope() : start_(allocations_in_process()) {}
  [[nodiscard]] long count() const { return allocations_in_process() - start_; }

 private:
  long start_;
};

}  // namespace hvac_twin::test
