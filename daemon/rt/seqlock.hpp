#pragma once
/// \file
/// Single-writer sequence lock: the RT thread (the only writer) never waits;
/// non-RT readers copy the protected data and retry if a write overlapped.
///
/// Fence-free form (Boehm, "Can seqlocks get along with programming language
/// memory models?", 2012), because ThreadSanitizer does not model
/// atomic_thread_fence: the protected data are atomics, written with
/// seq_store()/single_writer_add() (release) and read with seq_load()
/// (acquire). A reader that sees any value of a write in progress therefore
/// also sees that write's odd version on its second read, and retries. On
/// x86-64 release stores and acquire loads are plain moves: the RT side pays
/// two extra stores per update and never a locked instruction.

#include <atomic>
#include <cstdint>
#include <type_traits>

namespace hapticd::rt {

/// Store to seqlock-protected data (writer).
template <class U>
inline void seq_store(std::atomic<U>& a, std::type_identity_t<U> v) noexcept {
  a.store(v, std::memory_order_release);
}
/// Load of seqlock-protected data (reader, inside SeqlockVersion::read).
template <class U>
inline U seq_load(const std::atomic<U>& a) noexcept {
  return a.load(std::memory_order_acquire);
}
/// Single-writer increment: a load and a store, no locked read-modify-write,
/// because only one thread ever writes the value.
template <class U>
inline void single_writer_add(std::atomic<U>& a, std::type_identity_t<U> d) noexcept {
  seq_store(a, static_cast<U>(a.load(std::memory_order_relaxed) + d));
}

class SeqlockVersion {
 public:
  /// Writer: call before modifying the protected data.
  void write_begin() noexcept {
    version_.store(version_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);  // odd
  }
  /// Writer: call after modifying the protected data.
  void write_end() noexcept {
    version_.store(version_.load(std::memory_order_relaxed) + 1, std::memory_order_release);  // even
  }

  /// Reader: runs copy() until it saw no concurrent write, at most max_tries
  /// times. Returns true when the last copy is consistent.
  template <class Copy>
  bool read(Copy&& copy, int max_tries = 10000) const {
    for (int i = 0; i < max_tries; ++i) {
      const std::uint64_t before = version_.load(std::memory_order_acquire);
      if (before & 1u) continue;
      copy();  // seq_load()s: acquire, so the next load cannot move above them
      if (version_.load(std::memory_order_relaxed) == before) return true;
    }
    return false;
  }

 private:
  std::atomic<std::uint64_t> version_{0};
};

}  // namespace hapticd::rt
