#pragma once
/// \file
/// Single-writer sequence lock: the RT thread (the only writer) never waits;
/// non-RT readers copy the protected data and retry if a write overlapped.
/// The protected data must itself be relaxed atomics so that a torn read is
/// merely discarded, never undefined behaviour (and ThreadSanitizer agrees).

#include <atomic>
#include <cstdint>

namespace hapticd::rt {

class SeqlockVersion {
 public:
  /// Writer: call before modifying the protected data.
  void write_begin() noexcept {
    const std::uint64_t v = version_.load(std::memory_order_relaxed);
    version_.store(v + 1, std::memory_order_relaxed);  // odd: write in progress
    std::atomic_thread_fence(std::memory_order_release);
  }
  /// Writer: call after modifying the protected data.
  void write_end() noexcept {
    const std::uint64_t v = version_.load(std::memory_order_relaxed);
    version_.store(v + 1, std::memory_order_release);  // even: stable
  }

  /// Reader: runs copy() until it saw no concurrent write, at most max_tries
  /// times. Returns true when the last copy is consistent.
  template <class Copy>
  bool read(Copy&& copy, int max_tries = 10000) const {
    for (int i = 0; i < max_tries; ++i) {
      const std::uint64_t before = version_.load(std::memory_order_acquire);
      if (before & 1u) continue;
      copy();
      std::atomic_thread_fence(std::memory_order_acquire);
      if (version_.load(std::memory_order_relaxed) == before) return true;
    }
    return false;
  }

 private:
  std::atomic<std::uint64_t> version_{0};
};

/// Single-writer increment of a relaxed atomic: a load and a store, no locked
/// read-modify-write, because only one thread ever writes it.
template <class U>
inline void single_writer_add(std::atomic<U>& a, U d) noexcept {
  a.store(static_cast<U>(a.load(std::memory_order_relaxed) + d), std::memory_order_relaxed);
}

}  // namespace hapticd::rt
