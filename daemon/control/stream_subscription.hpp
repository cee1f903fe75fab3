#pragma once
/// \file
/// A client's telemetry stream (the built-in `stream` method): a timerfd
/// ticking at the asked rate, the channels asked for, and how many samples
/// were sent and lost.

#include <cstdint>
#include <string>
#include <vector>

namespace hapticd::daemon::control {

class StreamSubscription {
 public:
  StreamSubscription() = default;
  ~StreamSubscription() { stop(); }
  StreamSubscription(const StreamSubscription&) = delete;
  StreamSubscription& operator=(const StreamSubscription&) = delete;

  /// Starts (or replaces) the stream: arms the timer at rate_hz, restarts
  /// seq and dropped. Returns true when the timer was created now (the
  /// caller watches its fd). Throws RpcError busy when no timer can be made.
  bool start(std::uint64_t number, double rate_hz, std::vector<std::string> channels);
  /// Closes the timer; the stream is inactive afterwards. Idempotent.
  void stop();
  bool active() const noexcept { return timer_fd_ >= 0; }
  int timer_fd() const noexcept { return timer_fd_; }

  /// Timer periods elapsed since the last call (0 when none).
  std::uint64_t take_expirations();

  std::uint64_t number() const noexcept { return number_; }
  const std::vector<std::string>& channels() const noexcept { return channels_; }
  double rate_hz() const noexcept { return rate_hz_; }

  std::uint64_t seq = 0;      ///< notifications sent on this subscription
  std::uint64_t dropped = 0;  ///< samples this subscription lost

 private:
  int timer_fd_ = -1;
  std::uint64_t number_ = 0;
  std::vector<std::string> channels_;
  double rate_hz_ = 0.0;
};

}  // namespace hapticd::daemon::control
