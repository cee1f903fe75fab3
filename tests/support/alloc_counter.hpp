#pragma once
/// \file
/// Test-only proof that a code path does not allocate. Link the static
/// library `hapticd_alloc_counter` into a TEST executable (never into the
/// daemon): it replaces every global operator new/delete with versions that
/// count, on the calling thread only, while an AllocationGuard is alive.
///
///   hapticd::testing::AllocationGuard guard;
///   for (int i = 0; i < 1000; ++i) rt_path();
///   const auto n = guard.count();   // read before any gtest macro allocates
///   EXPECT_EQ(n, 0u);
///
/// Thread-local, so other threads (the test's producer, gtest itself) do not
/// disturb the count. Guards nest; the inner one counts only its own scope.

#include <cstddef>

namespace hapticd::testing {

class AllocationGuard {
 public:
  AllocationGuard() noexcept;
  ~AllocationGuard();
  AllocationGuard(const AllocationGuard&) = delete;
  AllocationGuard& operator=(const AllocationGuard&) = delete;

  /// Calls to any operator new on this thread since construction.
  std::size_t count() const noexcept;
  /// Calls to any operator delete (non-null) on this thread since construction.
  std::size_t deallocations() const noexcept;

 private:
  std::size_t start_allocs_;
  std::size_t start_frees_;
  bool was_armed_;
};

/// True when the replacement operators are linked in (a guard would count).
bool allocation_counting_active() noexcept;

}  // namespace hapticd::testing
