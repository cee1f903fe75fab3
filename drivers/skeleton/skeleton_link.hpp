#pragma once
/// \file
/// The skeleton driver's one transport file: the only place that makes
/// system calls (socket, connect, send, poll, recv, close). A real driver's
/// link opens its bus here (libusb, SocketCAN, libmodbus, libgpiod).

#include <cstdint>
#include <string>

#include "drivers/skeleton/skeleton_frame.hpp"

namespace hapticd::drivers::skeleton {

enum class LinkOutcome : std::uint8_t { ok, timeout, malformed, closed, io_error };

class SkeletonLink {
 public:
  SkeletonLink() = default;
  ~SkeletonLink() { close(); }
  SkeletonLink(const SkeletonLink&) = delete;
  SkeletonLink& operator=(const SkeletonLink&) = delete;

  /// connect(2) to the peer's SOCK_SEQPACKET socket; throws DeviceError
  /// ("socket") naming the path and the system's reason.
  void open(const std::string& path);
  void close() noexcept;
  bool is_open() const noexcept { return fd_ >= 0; }

  /// One exchange: sends the request, then waits up to `timeout_s` (poll)
  /// for the reply with its sequence; replies to earlier requests (late
  /// ones) are dropped and counted. No allocation: safe on the RT path.
  LinkOutcome exchange(const Request& request, Reply& reply, double timeout_s) noexcept;

  int last_errno() const noexcept { return last_errno_; }
  std::uint64_t stale_replies() const noexcept { return stale_replies_; }

 private:
  int fd_ = -1;
  int last_errno_ = 0;
  std::uint64_t stale_replies_ = 0;
};

/// "no reply within the response timeout", "malformed reply", ...
const char* describe(LinkOutcome outcome) noexcept;

}  // namespace hapticd::drivers::skeleton
