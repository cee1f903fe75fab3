#pragma once
/// \file
/// Lock-free hand-over of an immutable object (a scene plan) from the one
/// control thread to the RT thread, at a period boundary.
///
/// Why this shape:
/// - the writer allocates and fills the object outside RT and publishes it by
///   one atomic exchange into a single "pending" slot; a newer publication
///   replaces a pending one that the RT thread never saw (the writer deletes
///   that one itself: latest value wins, no queue builds up);
/// - the RT thread calls acquire() once per period: one exchange, no
///   allocation, no lock; it keeps the object as `current` for the period;
/// - the object it replaces is handed back through an SPSC ring and deleted by
///   the writer in collect(): the RT thread never frees memory;
/// - the RT thread records which publication took effect at which cycle in a
///   single-writer seqlock, so the writer can report "applied at cycle N".
///
/// Bound on the return ring: the writer collects at every publish, so at any
/// time the ring holds at most the object retired concurrently with that
/// collect plus the one retired when the new publication is taken (2 <
/// retire_capacity). retire_failures() counts the impossible overflow, which
/// would leak rather than free on the RT thread.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <thread>

#include "rt/seqlock.hpp"
#include "rt/spsc_ring.hpp"

namespace hapticd::rt {

template <class T>
class Mailbox {
 public:
  /// A publication that took effect: its sequence number (1, 2, ...; 0 means
  /// none yet) and the RT cycle number at which acquire() installed it.
  struct Applied {
    std::uint64_t seq = 0;
    std::uint64_t cycle = 0;
  };
  /// What publish() did.
  struct Publication {
    std::uint64_t seq = 0;             ///< this publication's sequence number
    std::uint64_t superseded_seq = 0;  ///< pending publication it replaced unseen (0: none)
  };

  static constexpr std::size_t retire_capacity = 8;

  Mailbox() : retired_(retire_capacity) {}
  Mailbox(const Mailbox&) = delete;
  Mailbox& operator=(const Mailbox&) = delete;
  /// Only when the RT thread no longer calls acquire()/current().
  ~Mailbox() {
    delete pending_.exchange(nullptr, std::memory_order_acquire);
    delete current_;
    collect();
  }

  // ---- writer (one non-RT thread) ----

  /// Publish a new object; it takes effect at the RT thread's next acquire().
  /// Throws std::invalid_argument on nullptr. Allocates (a small node).
  Publication publish(std::unique_ptr<T> value) {
    if (!value) throw std::invalid_argument("Mailbox::publish: null object");
    collect();
    auto node = std::make_unique<Node>();
    node->value = std::move(value);
    node->seq = ++last_seq_;
    Publication result{node->seq, 0};
    Node* unseen = pending_.exchange(node.release(), std::memory_order_acq_rel);
    if (unseen) {
      result.superseded_seq = unseen->seq;
      delete unseen;  // the RT thread never took it: still ours
    }
    return result;
  }

  /// Delete the objects the RT thread has retired. Returns how many.
  std::size_t collect() {
    std::size_t n = 0;
    Node* node = nullptr;
    while (retired_.try_pop(node)) {
      delete node;
      ++n;
    }
    return n;
  }

  /// Newest publication in effect and the cycle it took effect at.
  Applied applied() const {
    Applied a;
    applied_version_.read([&] {
      a.seq = seq_load(applied_seq_);
      a.cycle = seq_load(applied_cycle_);
    });
    return a;
  }

  /// Poll until publication `seq` (or a newer one) is in effect, or timeout.
  /// If the result's seq is newer than `seq`, `seq` was superseded or already
  /// replaced; Publication::superseded_seq of later publishes tells which.
  std::optional<Applied> wait_applied(std::uint64_t seq, std::chrono::nanoseconds timeout,
                                      std::chrono::microseconds poll = std::chrono::microseconds(100)) const {
    const auto end = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      const Applied a = applied();
      if (a.seq >= seq) return a;
      if (std::chrono::steady_clock::now() >= end) return std::nullopt;
      std::this_thread::sleep_for(poll);
    }
  }

  std::uint64_t last_published_seq() const noexcept { return last_seq_; }

  // ---- RT thread ----

  /// Once per period: install the newest pending object, if any, retire the
  /// previous one, and return the object in effect (nullptr before the first).
  const T* acquire(std::uint64_t cycle) noexcept {
    // Cheap check first: the common case is "nothing new" and a load does not
    // need exclusive ownership of the cache line as an exchange would.
    if (pending_.load(std::memory_order_relaxed) != nullptr) {
      if (Node* fresh = pending_.exchange(nullptr, std::memory_order_acq_rel)) {
        if (current_ && !retired_.try_push(current_)) single_writer_add(retire_failures_, std::uint64_t{1});
        current_ = fresh;
        applied_version_.write_begin();
        seq_store(applied_seq_, fresh->seq);
        seq_store(applied_cycle_, cycle);
        applied_version_.write_end();
      }
    }
    return current();
  }

  /// The object in effect (RT thread only).
  const T* current() const noexcept { return current_ ? current_->value.get() : nullptr; }

  /// Retirements that found the return ring full (should stay 0; see file comment).
  std::uint64_t retire_failures() const noexcept { return retire_failures_.load(std::memory_order_relaxed); }

 private:
  struct Node {
    std::unique_ptr<T> value;
    std::uint64_t seq = 0;
  };

  alignas(cache_line) std::atomic<Node*> pending_{nullptr};
  alignas(cache_line) Node* current_ = nullptr;  // RT thread only
  std::atomic<std::uint64_t> retire_failures_{0};
  SeqlockVersion applied_version_;
  std::atomic<std::uint64_t> applied_seq_{0};
  std::atomic<std::uint64_t> applied_cycle_{0};
  alignas(cache_line) std::uint64_t last_seq_ = 0;  // writer only
  SpscRing<Node*> retired_;
};

}  // namespace hapticd::rt
