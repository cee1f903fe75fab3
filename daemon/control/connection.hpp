#pragma once
/// \file
/// One client of the control server: its socket, the bytes read and not yet
/// handled (split into request lines), the reply bytes not yet sent, and its
/// telemetry stream. The server's loop decides when each is read or written.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "daemon/control/server.hpp"
#include "daemon/control/stream_subscription.hpp"

namespace hapticd::daemon::control {

class Connection {
 public:
  using Clock = std::chrono::steady_clock;

  /// Takes ownership of the connected socket `fd` (closed at destruction).
  Connection(int fd, PeerInfo peer);
  ~Connection();
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  int fd() const noexcept { return fd_; }
  std::uint64_t id() const noexcept { return peer_.client_id; }
  const PeerInfo& peer() const noexcept { return peer_; }

  // ---- input ----------------------------------------------------------------
  enum class Received { data, end_of_input, nothing, failed };
  /// One recv() into the input buffer (non-blocking).
  Received receive();

  /// A request is waiting: a complete line, or more than max_message_bytes
  /// without a '\n' (to be refused as too large).
  bool has_request(std::size_t max_message_bytes);
  /// The next complete line without taking it (empty when there is none).
  std::string_view peek_line();
  /// The next request line: complete (without its '\n'), none yet, or a line
  /// longer than the limit (complete or not).
  struct Line {
    enum class Kind { complete, incomplete, too_large } kind;
    std::string_view text;  ///< valid until the next receive() or discard_input()
  };
  Line next_line(std::size_t max_message_bytes);
  /// The bytes after the last complete line (a last line without '\n').
  std::string take_unterminated();
  bool has_input() const noexcept { return in_start_ < in_.size(); }
  void discard_input();

  // ---- output ---------------------------------------------------------------
  /// Appends one message line to the output queue.
  void queue(std::string_view line);
  enum class Sent { all, partly, peer_gone };
  /// Sends as much of the queue as the socket takes now.
  Sent send_queued();
  /// Bytes queued and not yet sent.
  std::size_t pending() const noexcept { return out_.size() - out_offset_; }

  // ---- state kept by the server's loop ----------------------------------------
  StreamSubscription stream;
  Clock::time_point last_activity = Clock::now();
  std::uint32_t events = 0;  ///< current epoll interest
  bool closing = false;      ///< close once the queue is sent
  /// Accepted over max_clients: only its first request is read, and only an
  /// estop or status is served (ServerOptions::over_limit_methods), until deadline.
  bool over_limit = false;
  Clock::time_point deadline{};
  bool dead = false;  ///< closed at the end of this epoll batch

 private:
  int fd_;
  PeerInfo peer_;
  std::string in_;
  std::size_t in_start_ = 0;  ///< bytes of in_ already taken as lines
  std::size_t scanned_ = 0;   ///< in_[in_start_, scanned_) holds no '\n'
  /// Position of the next '\n' after in_start_, or npos.
  std::size_t next_newline();
  std::string out_;
  std::size_t out_offset_ = 0;  ///< bytes of out_ already sent
};

}  // namespace hapticd::daemon::control
