#include "tests/support/allocation_counter.h"

#include <cstdlib>
#include <new>

// The replacements pair malloc with free; GCC cannot see that through
// inlined std::allocator and warns.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

namespace {
thread_local int g_counting = 0;
thread_local long g_allocations = 0;
}  // namespace

void* operator new(std::size_t size) {
  if (g_counting > 0) ++g_allocations;
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) { return operator new(size); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }

namespace kcrig {

AllocationCounter::AllocationCounter() : start_(g_allocations) { ++g_counting; }
AllocationCounter::~AllocationCounter() { --g_counting; }
long AllocationCounter::count() const { return g_allocations - start_; }

}  // namespace kcrig
