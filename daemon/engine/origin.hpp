#pragma once
/// \file
/// The device's origin (calibration): the position the device reports at
/// the place the user calls zero. The RT thread subtracts it from every
/// reading before anything else sees the position (scene, safety, telemetry,
/// recording); the position-step rule still checks the device's own
/// readings, so a new origin is never taken for an encoder jump.
///
/// A new origin reaches the RT thread through OriginHandover: lock-free, no
/// allocation, one request at a time. The control thread writes a request
/// (set this value, or take the position read in the coming cycle) and its
/// ticket; the RT thread takes it at its next cycle with a valid reading,
/// or drops it once the cycle it was valid until has passed, and says which
/// by storing the ticket as done. A request is written only when the last
/// one is done, so the RT thread never reads a request half written.

#include <atomic>
#include <cstdint>
#include <optional>

namespace hapticd::daemon::engine {

enum class OriginRequest : std::uint8_t {
  zero_here,  ///< the position read in the cycle that takes it becomes the origin (device.zero)
  set_value,  ///< a known origin (restored from the state directory)
};

/// What became of a request.
struct OriginOutcome {
  bool taken = false;       ///< false: dropped, no valid reading before it expired
  std::uint64_t cycle = 0;  ///< the cycle it took effect in (or was dropped at)
  double origin = 0.0;      ///< m or rad, in the device's own frame (the origin in force after it)
  double previous = 0.0;    ///< the origin before it
};

class OriginHandover {
 public:
  // ---- control thread (one at a time) ----

  /// False while the last request is not done yet (the RT thread has not
  /// reached it): nothing is written then.
  bool idle() const noexcept { return done_.load(std::memory_order_acquire) == requested_; }
  /// Writes a request valid up to and including `valid_until_cycle`; returns
  /// its ticket, or 0 when the last one is not done (see idle()).
  std::uint64_t request(OriginRequest kind, double value, std::uint64_t valid_until_cycle) noexcept {
    if (!idle()) return 0;
    kind_.store(kind, std::memory_order_relaxed);
    value_.store(value, std::memory_order_relaxed);
    valid_until_.store(valid_until_cycle, std::memory_order_relaxed);
    ++requested_;
    ticket_.store(requested_, std::memory_order_release);
    return requested_;
  }
  /// The outcome of `ticket` once the RT thread is done with it, while it
  /// is the last one done (a later request's outcome replaces it).
  std::optional<OriginOutcome> outcome(std::uint64_t ticket) const noexcept {
    if (ticket == 0 || done_.load(std::memory_order_acquire) != ticket) return std::nullopt;
    return OriginOutcome{taken_.load(std::memory_order_relaxed), cycle_.load(std::memory_order_relaxed),
                         origin_.load(std::memory_order_relaxed), previous_.load(std::memory_order_relaxed)};
  }

  // ---- RT thread ----

  struct Pending {
    OriginRequest kind = OriginRequest::zero_here;
    double value = 0.0;
    std::uint64_t valid_until_cycle = 0;
  };
  /// A request not yet done, if any (one acquire load when there is none).
  bool pending(Pending& out) const noexcept {
    if (ticket_.load(std::memory_order_acquire) == done_.load(std::memory_order_relaxed)) return false;
    out.kind = kind_.load(std::memory_order_relaxed);
    out.value = value_.load(std::memory_order_relaxed);
    out.valid_until_cycle = valid_until_.load(std::memory_order_relaxed);
    return true;
  }
  /// The pending request is done: taken (the new origin in force) or dropped.
  void complete(bool taken, std::uint64_t cycle, double origin, double previous) noexcept {
    taken_.store(taken, std::memory_order_relaxed);
    cycle_.store(cycle, std::memory_order_relaxed);
    origin_.store(origin, std::memory_order_relaxed);
    previous_.store(previous, std::memory_order_relaxed);
    done_.store(ticket_.load(std::memory_order_relaxed), std::memory_order_release);
  }

 private:
  std::uint64_t requested_ = 0;  ///< control thread only
  std::atomic<std::uint64_t> ticket_{0};
  std::atomic<OriginRequest> kind_{OriginRequest::zero_here};
  std::atomic<double> value_{0.0};
  std::atomic<std::uint64_t> valid_until_{0};
  std::atomic<std::uint64_t> done_{0};
  std::atomic<bool> taken_{false};
  std::atomic<std::uint64_t> cycle_{0};
  std::atomic<double> origin_{0.0};
  std::atomic<double> previous_{0.0};
};

static_assert(std::atomic<double>::is_always_lock_free);
static_assert(std::atomic<OriginRequest>::is_always_lock_free);

}  // namespace hapticd::daemon::engine
