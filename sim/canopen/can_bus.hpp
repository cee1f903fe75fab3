#pragma once
/// \file
/// The simulated CAN bus on the unix seam: `hapticd-devsim canbus --listen
/// unix:/path`. Every member (hapticd's canopen driver, each simulated drive
/// with --connect) connects to /path; every frame a member sends reaches
/// every other member, not the sender, as on a CAN bus (a CAN controller
/// does not receive its own frames unless it asks for loopback). Frames keep
/// their order per sender. A message that is no classic can_frame cannot
/// travel on a bus: it is counted and dropped. A member whose queue is full
/// misses that frame (counted), as a controller whose receive FIFO
/// overflowed; the relay never waits for a member.
///
/// Threads: run() or poll_once() on one thread; the counters from any.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "drivers/canopen/can_socket.hpp"

namespace hapticd::drivers::canopen::sim {

class CanBus {
 public:
  /// The most members at once (hapticd and up to six drives, with room).
  static constexpr std::size_t max_members = 16;

  /// Listens at `path`. Throws std::runtime_error.
  explicit CanBus(const std::string& path);
  ~CanBus();
  CanBus(const CanBus&) = delete;
  CanBus& operator=(const CanBus&) = delete;

  /// Serves until `stop` is set (checked at least every `tick`).
  void run(const std::atomic<bool>& stop, std::chrono::microseconds tick = std::chrono::milliseconds(10));
  /// One turn: waits up to `wait` for a frame or a member, accepts new
  /// members, relays every frame queued.
  void poll_once(std::chrono::microseconds wait);

  std::size_t members() const noexcept { return member_count_.load(); }
  std::uint64_t frames_relayed() const noexcept { return relayed_.load(); }  ///< frames received
  std::uint64_t deliveries_dropped() const noexcept { return dropped_.load(); }
  std::uint64_t malformed_messages() const noexcept { return malformed_.load(); }
  const std::string& path() const noexcept { return listener_.path(); }

 private:
  void accept_members();
  /// Every frame queued from member `from` to every other member.
  void relay_from(std::size_t from);
  void forward(std::size_t from, const cia301::Frame& frame);
  void drop_closed();

  CanListener listener_;
  std::vector<CanSocket> members_;
  std::vector<bool> closed_;
  std::atomic<std::size_t> member_count_{0};
  std::atomic<std::uint64_t> relayed_{0};
  std::atomic<std::uint64_t> dropped_{0};
  std::atomic<std::uint64_t> malformed_{0};
};

}  // namespace hapticd::drivers::canopen::sim
