#pragma once
/// \file
/// The simulated drive on the frame seam: listens at a unix path (the
/// driver's `interface = "unix:/path"`), serves one driver connection at a
/// time, feeds its frames to the SimulatedDrive and sends the drive's frames
/// back, and runs the drive's timers. A driver that goes away is to the drive
/// what a dead master is on a real bus: its heartbeat stops. The bus keeps
/// listening, so hapticd can be restarted against the same drive.
///
/// Or, as a member of a simulated bus (can_bus.hpp, `hapticd-devsim canbus`):
/// connects to it and hears every frame the other members send (hapticd's,
/// and the other drives', which it ignores by their COB-IDs as CiA 301 has
/// it); its boot-up goes to the bus. A bus that ends is the drive's cable
/// pulled: it serves no one until the program restarts.
///
/// Threads: run() on one thread; command() from any thread (a mutex guards
/// the drive: this is the simulator, not the RT side).

#include <atomic>
#include <chrono>
#include <mutex>
#include <string>

#include "drivers/canopen/can_socket.hpp"
#include "sim/canopen/simulated_drive.hpp"

namespace hapticd::drivers::canopen::sim {

class DriveBus {
 public:
  /// Listens at `path` and powers the drive on. Throws std::runtime_error.
  DriveBus(const std::string& path, SimulatedDrive& drive);
  struct Member {};
  /// Connects to the bus at `path` as one member of it and powers the drive
  /// on (its boot-up goes to the bus). Throws std::runtime_error.
  DriveBus(Member, const std::string& path, SimulatedDrive& drive);
  ~DriveBus();

  /// Serves until `stop` is set (checked at least every `tick`).
  void run(const std::atomic<bool>& stop, std::chrono::microseconds tick = std::chrono::milliseconds(1));
  /// One turn of the loop: waits up to `wait` for a frame or a connection.
  void poll_once(std::chrono::microseconds wait);
  /// A fault switch or status request (sim/commands.hpp); returns the reply line.
  std::string command(const std::string& line);

  bool connected() const;
  /// Processes every frame already queued from the driver (tests: what the
  /// drive applies after the frames sent so far), then returns.
  void settle() { poll_once(std::chrono::microseconds(0)); }
  /// The force the drive applies now (N m or N), read under the bus's lock.
  double applied_force() const;
  std::uint64_t connections() const noexcept { return connections_.load(); }
  const std::string& path() const noexcept { return member_ ? bus_path_ : listener_.path(); }

 private:
  Micros now() const;
  void send_all(const std::vector<Frame>& frames);

  SimulatedDrive& drive_;
  bool member_ = false;
  std::string bus_path_;  ///< member: the bus' path
  CanListener listener_;  ///< not open for a member
  CanSocket connection_;
  mutable std::mutex mutex_;
  std::atomic<std::uint64_t> connections_{0};
  std::chrono::steady_clock::time_point epoch_ = std::chrono::steady_clock::now();
};

}  // namespace hapticd::drivers::canopen::sim
