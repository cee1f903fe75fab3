// Replacement global allocation functions (all the forms [new.delete] lets a
// program replace), counting per thread while armed. Plain malloc/free
// underneath, so sanitizers still see every allocation.
#include "tests/support/alloc_counter.hpp"

#include <cstdlib>
#include <new>

namespace {

// Trivial thread_locals: no TLS init function, safe inside operator new.
thread_local bool armed = false;
thread_local std::size_t allocs = 0;
thread_local std::size_t frees = 0;

void* counted_alloc(std::size_t size, std::size_t align) noexcept {
  if (armed) ++allocs;
  if (size == 0) size = 1;
  if (align <= alignof(std::max_align_t)) return std::malloc(size);
  void* p = nullptr;
  return ::posix_memalign(&p, align, size) == 0 ? p : nullptr;
}

void* counted_alloc_or_throw(std::size_t size, std::size_t align) {
  for (;;) {
    if (void* p = counted_alloc(size, align)) return p;
    std::new_handler h = std::get_new_handler();
    if (!h) throw std::bad_alloc();
    h();
  }
}

void counted_free(void* p) noexcept {
  if (!p) return;
  if (armed) ++frees;
  std::free(p);
}

}  // namespace

namespace hapticd::testing {

AllocationGuard::AllocationGuard() noexcept : start_allocs_(allocs), start_frees_(frees), was_armed_(armed) {
  armed = true;
}
AllocationGuard::~AllocationGuard() { armed = was_armed_; }
std::size_t AllocationGuard::count() const noexcept { return allocs - start_allocs_; }
std::size_t AllocationGuard::deallocations() const noexcept { return frees - start_frees_; }

bool allocation_counting_active() noexcept {
  AllocationGuard g;
  void* p = ::operator new(1);
  const std::size_t n = g.count();
  ::operator delete(p);
  return n == 1;
}

}  // namespace hapticd::testing

constexpr std::size_t default_align = alignof(std::max_align_t);

void* operator new(std::size_t n) { return counted_alloc_or_throw(n, default_align); }
void* operator new[](std::size_t n) { return counted_alloc_or_throw(n, default_align); }
void* operator new(std::size_t n, const std::nothrow_t&) noexcept { return counted_alloc(n, default_align); }
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
  return counted_alloc(n, default_align);
}
void* operator new(std::size_t n, std::align_val_t a) {
  return counted_alloc_or_throw(n, static_cast<std::size_t>(a));
}
void* operator new[](std::size_t n, std::align_val_t a) {
  return counted_alloc_or_throw(n, static_cast<std::size_t>(a));
}
void* operator new(std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  return counted_alloc(n, static_cast<std::size_t>(a));
}
void* operator new[](std::size_t n, std::align_val_t a, const std::nothrow_t&) noexcept {
  return counted_alloc(n, static_cast<std::size_t>(a));
}

void operator delete(void* p) noexcept { counted_free(p); }
void operator delete[](void* p) noexcept { counted_free(p); }
void operator delete(void* p, std::size_t) noexcept { counted_free(p); }
void operator delete[](void* p, std::size_t) noexcept { counted_free(p); }
void operator delete(void* p, const std::nothrow_t&) noexcept { counted_free(p); }
void operator delete[](void* p, const std::nothrow_t&) noexcept { counted_free(p); }
void operator delete(void* p, std::align_val_t) noexcept { counted_free(p); }
void operator delete[](void* p, std::align_val_t) noexcept { counted_free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { counted_free(p); }
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept { counted_free(p); }
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept { counted_free(p); }
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept { counted_free(p); }
