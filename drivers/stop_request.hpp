#pragma once
/// \file
/// Giving way to the daemon's stop (SIGTERM, SIGINT) in the lifecycle's
/// blocking steps. The framework owns one StopRequest (the daemon's signal
/// thread sets it) and hands its token to the driver in LoopContext at
/// configure(); the driver keeps it for enable() and clear_fault().
///
/// The rule for a driver: every blocking wait of configure, enable and
/// clear_fault (a reply, a state, a sleep) is cut into slices of at most
/// stop_slice and looks at the token between them. Once a stop is
/// requested the step ends at the end of its slice, undoes what it half did
/// (torque 0, power stage off, a line released) and throws StopRequested.
/// A wait that begins after the stop still gets its one slice, so disable()
/// and close() on the way out still reach a live device, while a dead one
/// no longer holds the exit for a whole timeout. The RT calls (read, write)
/// never look at the token: they do not block.

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <stop_token>
#include <string>

namespace hapticd::drivers {

/// The longest a lifecycle wait runs without looking at the stop request:
/// SIGTERM ends configure, enable or a fault clear within it (the unit's
/// TimeoutStopSec is 5 s).
inline constexpr std::chrono::milliseconds stop_slice{100};

/// What a driver holds. Default-constructed: never stops (tests, tools).
using StopToken = std::stop_token;

/// A lifecycle step that gave way to a stop request. Not a DeviceError: the
/// device is not at fault and no config key is to blame.
class StopRequested : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The framework's side: one per daemon, set once by whoever takes the
/// stop signals (any thread, not a signal handler).
class StopRequest {
 public:
  /// `why` names the cause for the log ("SIGTERM"); a string literal.
  void request(const char* why) noexcept;
  bool requested() const noexcept { return source_.stop_requested(); }
  /// The cause, "" before any request.
  const char* why() const noexcept {
    const char* why = why_.load(std::memory_order_acquire);
    return why != nullptr ? why : "";
  }
  StopToken token() const noexcept { return source_.get_token(); }

 private:
  std::stop_source source_;
  // nullptr until the first request: a pointer compared against a "" of
  // another translation unit matches only where the compiler merges literals.
  std::atomic<const char*> why_{nullptr};
};

/// One bounded wait of a lifecycle step, in slices: block for next_slice()
/// at a time until the awaited thing happens, expired(), or stopped().
class SlicedWait {
 public:
  using Clock = std::chrono::steady_clock;
  SlicedWait(StopToken stop, Clock::duration timeout);
  /// How long the next blocking call may block: the time left, at most one slice (>= 0).
  Clock::duration next_slice() const noexcept;
  bool expired() const noexcept { return Clock::now() >= deadline_; }
  bool stopped() const noexcept { return stop_.stop_requested(); }
  Clock::time_point deadline() const noexcept { return deadline_; }

 private:
  StopToken stop_;
  Clock::time_point deadline_;
};

/// Sleeps `duration` in slices; false when a stop request cut it short.
bool sleep_unless_stopped(const StopToken& stop, std::chrono::steady_clock::duration duration);

/// Throws StopRequested("<what>: abandoned, hapticd is stopping") when a stop was requested.
void throw_if_stopped(const StopToken& stop, const std::string& what);

/// The text of StopRequested for `what` (the step given up).
std::string abandoned(const std::string& what);

}  // namespace hapticd::drivers
