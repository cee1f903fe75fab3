#pragma once
// Counts C allocations (malloc, calloc, realloc) on the calling thread, so a
// test can show that libmodbus, a C library, allocates nothing on the RT
// path. The test executable defines malloc/calloc/realloc/free, which
// interpose the C library's for every library in the process (ELF symbol
// interposition), and forwards to glibc's __libc_* entry points. Test-only.
#include <cstddef>

namespace hapticd::drivers::modbus::testing {

class CAllocationGuard {
 public:
  CAllocationGuard() noexcept;
  ~CAllocationGuard();
  CAllocationGuard(const CAllocationGuard&) = delete;
  CAllocationGuard& operator=(const CAllocationGuard&) = delete;
  std::size_t count() const noexcept;

 private:
  std::size_t start_;
  bool was_armed_;
};

/// True when the interposed allocator is the one in use (a guard counts).
bool c_allocation_counting_active() noexcept;

}  // namespace hapticd::drivers::modbus::testing
