// The counting replacements of the global allocation functions (alloc_counter.hpp).
#include "tests/support/alloc_counter.hpp"

#include <atomic>
#include <cstdlib>
#include <new>

namespace {
std::atomic<long> g_allocations{0};
thread_local long t_allocations = 0;
std::atomic<std::thread::id> g_watched{};
std::atomic<long> g_watched_allocations{0};

void* counted_malloc(std::size_t size) noexcept {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  ++t_allocations;
  if (std::this_thread::get_id() == g_watched.load(std::memory_order_relaxed))
    g_watched_allocations.fetch_add(1, std::memory_order_relaxed);
  return std::malloc(size == 0 ? 1 : size);
}
}  // namespace

namespace hvac_twin::test {

long allocations_in_process() {
  return g_allocations.load(std::memory_order_relaxed);
}

long allocations_on_this_thread() {
  return t_allocations;
}

void watch_allocations_of(std::thread::id thread) {
  g_watched.store(thread);
  g_watched_allocations.store(0);
}

long watched_allocations() {
  return g_watched_allocations.load();
}

}  // namespace hvac_twin::test

void* operator new(std::size_t size) {
  if (void* p = counted_malloc(size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) {
  if (void* p = counted_malloc(size)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  return counted_malloc(size);
}
void* operator new[](std::size_t size, const std::nothrow_t&) noexcept {
  return counted_malloc(size);
}
// GCC flags free() of memory from a replaced operator new as mismatched; here it is the match.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete[](void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
  std::free(p);
}
void operator delete(void* p, const std::nothrow_t&) noexcept {
  std::free(p);
}
void operator delete[](void* p, const std::nothrow_t&) noexcept {
  std::free(p);
}
#pragma GCC diagnostic pop
