#pragma once
/// \file
/// Single-producer / single-consumer lock-free ring. Used for telemetry
/// (RT thread -> recorder) and for handing retired plans back to the control
/// thread. Why this shape:
/// - storage is allocated once in the constructor (outside RT); push and pop
///   never allocate, lock or block, so the RT side is wait-free;
/// - a full ring drops the new element and counts it on the producer side:
///   the RT thread must never wait for a slow consumer;
/// - head and tail live on separate cache lines (with each side's cached copy
///   of the other index) so producer and consumer do not false-share;
/// - release on publish / acquire on observe is all the ordering needed.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <type_traits>

namespace hapticd::rt {

/// Cache line size used for padding. A constant (not
/// std::hardware_destructive_interference_size) so the layout does not change
/// with compiler flags; 64 bytes is right for every x86-64 and most arm64 cores.
inline constexpr std::size_t cache_line = 64;

template <class T>
class SpscRing {
  static_assert(std::is_trivially_copyable_v<T>, "SpscRing copies elements with plain stores");

 public:
  /// capacity: a power of two >= 2. Throws std::invalid_argument otherwise.
  explicit SpscRing(std::size_t capacity)
      : capacity_(checked_capacity(capacity)), mask_(capacity - 1), slots_(std::make_unique<T[]>(capacity)) {}

  SpscRing(const SpscRing&) = delete;
  SpscRing& operator=(const SpscRing&) = delete;

  /// Producer only. Returns false (and counts a drop) when the ring is full.
  bool try_push(const T& value) noexcept {
    const std::uint64_t head = producer_.head.load(std::memory_order_relaxed);
    if (head - producer_.cached_tail >= capacity_) {
      producer_.cached_tail = tail_.value.load(std::memory_order_acquire);
      if (head - producer_.cached_tail >= capacity_) {
        // Single writer: a plain load + store is enough and cheaper than an RMW.
        producer_.dropped.store(producer_.dropped.load(std::memory_order_relaxed) + 1,
                                std::memory_order_relaxed);
        return false;
      }
    }
    slots_[head & mask_] = value;
    producer_.head.store(head + 1, std::memory_order_release);
    return true;
  }

  /// Consumer only. Returns false when the ring is empty.
  bool try_pop(T& out) noexcept {
    const std::uint64_t tail = tail_.value.load(std::memory_order_relaxed);
    if (tail == consumer_.cached_head) {
      consumer_.cached_head = producer_.head.load(std::memory_order_acquire);
      if (tail == consumer_.cached_head) return false;
    }
    out = slots_[tail & mask_];
    tail_.value.store(tail + 1, std::memory_order_release);
    return true;
  }

  /// Consumer only. Pops up to out.size() elements in order; returns how many.
  std::size_t pop_bulk(std::span<T> out) noexcept {
    const std::uint64_t tail = tail_.value.load(std::memory_order_relaxed);
    consumer_.cached_head = producer_.head.load(std::memory_order_acquire);
    const std::uint64_t available = consumer_.cached_head - tail;
    const std::size_t n = available < out.size() ? static_cast<std::size_t>(available) : out.size();
    for (std::size_t i = 0; i < n; ++i) out[i] = slots_[(tail + i) & mask_];
    tail_.value.store(tail + n, std::memory_order_release);
    return n;
  }

  /// Number of elements in the ring. Exact when called by producer or consumer
  /// while the other side is idle; otherwise a snapshot that may be stale.
  std::size_t size() const noexcept {
    const std::uint64_t tail = tail_.value.load(std::memory_order_acquire);
    const std::uint64_t head = producer_.head.load(std::memory_order_acquire);
    return static_cast<std::size_t>(head - tail);
  }
  bool empty() const noexcept { return size() == 0; }
  std::size_t capacity() const noexcept { return capacity_; }
  /// Pushes refused because the ring was full (readable from any thread).
  std::uint64_t dropped() const noexcept { return producer_.dropped.load(std::memory_order_relaxed); }

 private:
  static std::size_t checked_capacity(std::size_t c) {
    if (c < 2 || (c & (c - 1)) != 0)
      throw std::invalid_argument("SpscRing capacity must be a power of two >= 2");
    return c;
  }

  // Producer-owned line: head index, producer's view of tail, drop counter.
  struct alignas(cache_line) ProducerSide {
    std::atomic<std::uint64_t> head{0};
    std::uint64_t cached_tail = 0;
    std::atomic<std::uint64_t> dropped{0};
  };
  // Consumer-owned line: tail index.
  struct alignas(cache_line) TailIndex {
    std::atomic<std::uint64_t> value{0};
  };
  // Consumer-private cached view of head (kept off the producer's line).
  struct alignas(cache_line) ConsumerCache {
    std::uint64_t cached_head = 0;
  };

  const std::size_t capacity_;
  const std::size_t mask_;
  std::unique_ptr<T[]> slots_;
  ProducerSide producer_;
  TailIndex tail_;
  ConsumerCache consumer_;
};

}  // namespace hapticd::rt
