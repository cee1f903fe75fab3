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
#include <chrono>
#include <cstdint>
#include <thread>
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

  /// Reader (non-RT): runs copy() until it saw no concurrent write. Spins a
  /// few times, then yields: the writer is the RT thread, and if it is
  /// preempted (or the host stalls its vCPU) between write_begin() and
  /// write_end() the version stays odd for milliseconds, far longer than any
  /// spin budget. Gives up only after `give_up_after` (a writer that never
  /// finishes its two stores); returns whether the last copy is consistent.
  template <class Copy>
  bool read(Copy&& copy, std::chrono::nanoseconds give_up_after = std::chrono::seconds(1)) const {
    constexpr int spins_before_yield = 64;
    std::chrono::steady_clock::time_point deadline{};
    for (int attempt = 0;; ++attempt) {
      const std::uint64_t before = version_.load(std::memory_order_acquire);
      if ((before & 1U) == 0) {
        copy();  // seq_load()s: acquire, so the next load cannot move above them
        if (version_.load(std::memory_order_relaxed) == before) return true;
      }
      if (attempt < spins_before_yield) continue;
      const auto now = std::chrono::steady_clock::now();
      if (attempt == spins_before_yield) deadline = now + give_up_after;
      if (now >= deadline) return false;
      std::this_thread::yield();
    }
  }

 private:
  std::atomic<std::uint64_t> version_{0};
};

}  // namespace hapticd::rt
