#pragma once
/// \file
/// UDP telemetry for PlotJuggler (docs/config.md, [telemetry]): a non-RT
/// sender thread fed from the recorder thread's drain. The RT thread is not
/// involved: the recorder hands every drained batch to offer(), which keeps
/// every N-th cycle (N = the loop rate / rate_hz, rounded) in a queue of
/// its own (an SPSC ring: the recorder thread pushes, the sender pops); the
/// sender formats datagrams (datagram.hpp) and sends them non-blocking.
/// Nothing waits on anybody: a full queue (the sender fell behind, e.g.
/// with the virtual clock's fast runs), a full socket buffer or a refused
/// port (ICMP, on the connected socket) drops datagrams and counts them.
/// Datagrams a receiver drops itself (its own buffer full) are not visible
/// to the sender: the receiver's kernel counts them (Udp RcvbufErrors).

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "daemon/telemetry.hpp"
#include "daemon/telemetry/udp_endpoint.hpp"
#include "rt/spsc_ring.hpp"

namespace hapticd::daemon::telemetry {

inline constexpr std::uint32_t max_batch = 64;
inline constexpr double min_rate_hz = 0.1;

struct Settings {
  bool enabled = false;
  std::optional<UdpEndpoint> udp;
  double rate_hz = 100.0;             ///< asked for; every decimation-th cycle is sent
  std::vector<std::string> channels;  ///< empty: the recording's columns
  std::uint32_t batch = 1;            ///< samples per datagram (1: a bare object)
  std::string prefix = "hapticd";     ///< the object holding the channels: /hapticd/position
};

/// Since the daemon started.
struct Counters {
  std::uint64_t samples_queued = 0;        ///< kept by the decimation and queued
  std::uint64_t dropped_queue = 0;         ///< not queued: the queue was full (the sender fell behind)
  std::uint64_t samples_sent = 0;          ///< in datagrams the kernel took
  std::uint64_t datagrams_sent = 0;        ///< the kernel took them
  std::uint64_t datagrams_dropped = 0;     ///< send() failed
  std::uint64_t samples_dropped_send = 0;  ///< in the datagrams that failed
  std::uint64_t buffer_full = 0;           ///< failures: EAGAIN / ENOBUFS, the socket buffer full
  std::uint64_t refused = 0;               ///< failures: ECONNREFUSED, nobody listens on the port
  std::uint64_t non_finite = 0;            ///< values sent as null (NaN or Inf)
  std::string last_error;                  ///< the last send error ("" if none)
};

class TelemetryError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class UdpTelemetry {
 public:
  /// period_s: the loop's period (t = cycle * period). Starts the sender thread.
  explicit UdpTelemetry(double period_s, std::size_t queue_capacity = 8192);
  ~UdpTelemetry();  ///< stop()
  /// Sends what is queued (non-blocking: what does not go is counted) and
  /// joins the sender; offer() must no longer be called. Idempotent;
  /// counters() stay readable.
  void stop();
  UdpTelemetry(const UdpTelemetry&) = delete;
  UdpTelemetry& operator=(const UdpTelemetry&) = delete;

  /// Takes new settings (validated by the caller: rate, batch, prefix,
  /// channels). Opens and connects a socket when the address changes; throws
  /// TelemetryError when that fails (the old settings stay).
  void apply(const Settings& settings);
  Settings settings() const;
  /// Every decimation-th cycle is sent: round(1 / (rate_hz * period)), >= 1.
  std::uint64_t decimation() const noexcept { return decimation_.load(std::memory_order_relaxed); }
  double period_s() const noexcept { return period_s_; }

  /// The scene's channel names from cycle first_cycle on (earlier samples
  /// still queued keep the previous names). Ends a hold_for_scene().
  void set_scene(std::vector<std::string> scene_channels, std::uint64_t first_cycle);
  /// A new scene is being published: the cycle it takes effect at is known
  /// only once the loop took it, so the sender formats nothing until
  /// set_scene() says (at most 3 s: then with the names it has). The
  /// samples wait in the queue.
  void hold_for_scene();

  /// The recorder thread's drained batch (the only producer). Never blocks.
  void offer(std::span<const TelemetrySample> batch) noexcept;

  Counters counters() const;

 private:
  struct SenderState;
  void run();
  void refresh(SenderState& state);
  bool held() const;  ///< hold_for_scene() in force (never once stopping)
  void send_datagram(SenderState& state);
  void format(SenderState& state, const TelemetrySample& sample);

  const double period_s_;
  const std::int64_t period_ns_;
  rt::SpscRing<TelemetrySample> queue_;
  std::atomic<bool> enabled_{false};
  std::atomic<std::uint64_t> decimation_{1};
  std::atomic<std::uint64_t> queued_{0};  ///< written by the producer only

  mutable std::mutex mutex_;  ///< guards everything below; never held during send()
  std::condition_variable wake_;
  Settings settings_;
  int next_fd_ = -1;  ///< a socket apply() opened, not yet taken by the sender
  bool fd_changed_ = false;
  std::uint64_t generation_ = 1;
  std::vector<std::string> scene_previous_, scene_current_;
  std::uint64_t scene_first_cycle_ = 0;
  std::chrono::steady_clock::time_point hold_until_{};
  Counters counters_;  ///< the sender's counts (queue counts come from the ring)
  bool quit_ = false;

  std::thread thread_;
};

}  // namespace hapticd::daemon::telemetry
