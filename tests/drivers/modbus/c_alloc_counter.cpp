#include "c_alloc_counter.hpp"

#include <cstdlib>

extern "C" {
void* __libc_malloc(std::size_t size);
void* __libc_calloc(std::size_t count, std::size_t size);
void* __libc_realloc(void* pointer, std::size_t size);
void __libc_free(void* pointer);
}

namespace {
// Trivially initialized thread-locals of the executable: static TLS, no
// allocation to reach them.
thread_local std::size_t t_allocations = 0;
thread_local bool t_armed = false;
}  // namespace

// Not under a sanitizer: its own malloc must stay in place (the replacement
// crashed TSan and ASan at start); the allocation tests skip there and run
// in the normal build.
#ifndef HAPTICD_SANITIZED
extern "C" void* malloc(std::size_t size) noexcept {
  if (t_armed) ++t_allocations;
  return __libc_malloc(size);
}
extern "C" void* calloc(std::size_t count, std::size_t size) noexcept {
  if (t_armed) ++t_allocations;
  return __libc_calloc(count, size);
}
extern "C" void* realloc(void* pointer, std::size_t size) noexcept {
  if (t_armed) ++t_allocations;
  return __libc_realloc(pointer, size);
}
extern "C" void free(void* pointer) noexcept { __libc_free(pointer); }
#endif

namespace hapticd::drivers::modbus::testing {

CAllocationGuard::CAllocationGuard() noexcept : start_(t_allocations), was_armed_(t_armed) { t_armed = true; }
CAllocationGuard::~CAllocationGuard() { t_armed = was_armed_; }
std::size_t CAllocationGuard::count() const noexcept { return t_allocations - start_; }

bool c_allocation_counting_active() noexcept {
  const std::size_t before = t_allocations;
  const bool armed = t_armed;
  t_armed = true;
  void* volatile p = std::malloc(16);
  t_armed = armed;
  std::free(p);
  return t_allocations != before;
}

}  // namespace hapticd::drivers::modbus::testing
