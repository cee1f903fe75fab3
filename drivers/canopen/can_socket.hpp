#pragma once
/// \file
/// The one file of the canopen driver that makes system calls: a socket
/// carrying classic CAN frames (16-byte `struct can_frame`, host byte order).
///   - "can0", "vcan0", ...: PF_CAN / SOCK_RAW / CAN_RAW bound to the
///     interface, receive filters for the node's COB-IDs, error frames
///     through CAN_RAW_ERR_FILTER, a larger SO_RCVBUF;
///   - "unix:/path": AF_UNIX / SOCK_SEQPACKET connected to the simulated bus
///     listening at /path (one message = one struct can_frame, message
///     boundaries kept); the same filters are applied here in user space, so
///     both transports deliver the same frames.
/// Every socket is non-blocking: send() and receive() never wait. A full TX
/// queue (ENOBUFS on CAN, EAGAIN) drops the frame and says so.

#include <chrono>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "drivers/canopen/301/frame.hpp"
#include "drivers/canopen/can_error.hpp"

namespace hapticd::drivers::canopen {

/// One receive filter (as struct can_filter): a frame passes when
/// (frame.id & mask) == (id & mask).
struct CanFilter {
  std::uint32_t id = 0;
  std::uint32_t mask = 0;
};
/// An exact match on an 11-bit data frame (RTR and 29-bit frames excluded).
CanFilter exact_standard_filter(std::uint32_t id) noexcept;

enum class IoStatus : std::uint8_t {
  ok,
  would_block,  ///< receive: nothing queued; send: TX queue full (frame dropped)
  closed,       ///< the peer closed the connection (unix: transport only)
  error,        ///< another error (errno in last_errno())
  malformed,    ///< receive: a message that is no classic can_frame (last_malformed() says what)
};

class CanSocket {
 public:
  CanSocket() = default;
  ~CanSocket();
  CanSocket(CanSocket&& other) noexcept;
  CanSocket& operator=(CanSocket&& other) noexcept;
  CanSocket(const CanSocket&) = delete;
  CanSocket& operator=(const CanSocket&) = delete;

  /// Opens `interface` ("can0" or "unix:/path"). `filters` empty = receive
  /// everything; `error_classes` = the CAN_ERR_* classes to receive.
  /// Throws std::runtime_error with one line naming the interface, what failed
  /// and what to do.
  static CanSocket open(std::string_view interface, std::span<const CanFilter> filters,
                        std::uint32_t error_classes);
  /// A connected AF_UNIX SOCK_SEQPACKET pair (tests, in-process peers).
  static std::pair<CanSocket, CanSocket> pair();

  /// Non-blocking; RT-safe (one send(2) or recv(2), no allocation).
  IoStatus send(const cia301::Frame& frame) noexcept;
  /// A message of another size (or a can_frame with len > 8) is consumed and
  /// returned as malformed, never cut to a frame; an empty message on the
  /// unix seam is malformed too while the peer lives (closed once it hung up).
  IoStatus receive(cia301::Frame& frame) noexcept;
  int last_errno() const noexcept { return last_errno_; }
  const MalformedMessage& last_malformed() const noexcept { return malformed_; }

  /// Non-RT: waits until a frame can be read or `timeout` passes (poll(2));
  /// false on timeout. A closed peer counts as readable.
  bool wait_readable(std::chrono::microseconds timeout) const;

  bool is_open() const noexcept { return fd_ >= 0; }
  bool is_unix() const noexcept { return unix_; }
  int fd() const noexcept { return fd_; }
  void close() noexcept;

  /// Replaces the receive filters (non-RT).
  void set_filters(std::span<const CanFilter> filters, std::uint32_t error_classes);

 private:
  friend class CanListener;
  CanSocket(int fd, bool unix_transport) : fd_(fd), unix_(unix_transport) {}
  bool passes(const cia301::Frame& frame) const noexcept;

  int fd_ = -1;
  bool unix_ = false;
  bool peer_hung_up() const noexcept;

  int last_errno_ = 0;
  MalformedMessage malformed_;
  std::vector<CanFilter> filters_;  // user-space filters (unix transport); fixed after open
  std::uint32_t error_classes_ = 0;
};

/// The simulated bus end: listens at a unix path for the driver to connect.
class CanListener {
 public:
  CanListener() = default;
  ~CanListener();
  CanListener(CanListener&& other) noexcept;
  CanListener& operator=(CanListener&& other) noexcept;
  CanListener(const CanListener&) = delete;
  CanListener& operator=(const CanListener&) = delete;

  /// Creates the socket file at `path` (replacing a stale socket there, never
  /// another kind of file). `backlog`: connections that may wait to be
  /// accepted (a drive serves one; the simulated bus, every member). Throws
  /// std::runtime_error.
  static CanListener listen(const std::string& path, int backlog = 1);
  /// Waits up to `timeout` for the driver; an unopened socket on timeout.
  CanSocket accept(std::chrono::microseconds timeout);
  int fd() const noexcept { return fd_; }
  const std::string& path() const noexcept { return path_; }
  void close() noexcept;  ///< closes and removes the socket file

 private:
  int fd_ = -1;
  std::string path_;
};

/// "unix:/path" -> "/path"; "" for a CAN interface name.
std::string_view unix_path_of(std::string_view interface) noexcept;

}  // namespace hapticd::drivers::canopen
