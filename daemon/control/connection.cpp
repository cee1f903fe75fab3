#include "daemon/control/connection.hpp"

#include <algorithm>
#include <cerrno>

#include <sys/socket.h>
#include <unistd.h>

namespace hapticd::daemon::control {

Connection::Connection(int fd, PeerInfo peer) : fd_(fd), peer_(peer) {}

Connection::~Connection() {
  stream.stop();
  ::close(fd_);
}

Connection::Received Connection::receive() {
  if (in_start_ > 0) {
    in_.erase(0, in_start_);
    scanned_ -= std::min(scanned_, in_start_);
    in_start_ = 0;
  }
  char buf[65536];
  for (;;) {
    ssize_t n = ::recv(fd_, buf, sizeof(buf), 0);
    if (n > 0) {
      in_.append(buf, static_cast<std::size_t>(n));
      return Received::data;
    }
    if (n == 0) return Received::end_of_input;
    if (errno == EINTR) continue;
    return errno == EAGAIN || errno == EWOULDBLOCK ? Received::nothing : Received::failed;
  }
}

std::size_t Connection::next_newline() {
  // Remembers how far it looked: a long line arriving in pieces is not
  // searched again from its start on every piece.
  const std::size_t nl = in_.find('\n', std::max(in_start_, scanned_));
  scanned_ = nl == std::string::npos ? in_.size() : nl;
  return nl;
}

bool Connection::has_request(std::size_t max_message_bytes) {
  return next_newline() != std::string::npos || in_.size() - in_start_ > max_message_bytes;
}

std::string_view Connection::peek_line() {
  const std::size_t nl = next_newline();
  if (nl == std::string::npos) return {};
  return std::string_view(in_.data() + in_start_, nl - in_start_);
}

Connection::Line Connection::next_line(std::size_t max_message_bytes) {
  const std::size_t nl = next_newline();
  if (nl == std::string::npos) {
    if (in_.size() - in_start_ > max_message_bytes) return {Line::Kind::too_large, {}};
    return {Line::Kind::incomplete, {}};
  }
  if (nl - in_start_ > max_message_bytes) return {Line::Kind::too_large, {}};
  std::string_view text(in_.data() + in_start_, nl - in_start_);
  in_start_ = nl + 1;
  return {Line::Kind::complete, text};
}

std::string Connection::take_unterminated() {
  std::string rest = in_.substr(in_start_);
  discard_input();
  return rest;
}

void Connection::discard_input() {
  in_.clear();
  in_start_ = 0;
  scanned_ = 0;
}

void Connection::queue(std::string_view line) {
  if (out_offset_ > 0 && out_offset_ >= out_.size() / 2) {
    out_.erase(0, out_offset_);
    out_offset_ = 0;
  }
  out_ += line;
}

Connection::Sent Connection::send_queued() {
  while (pending() > 0) {
    ssize_t n = ::send(fd_, out_.data() + out_offset_, pending(), MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      out_offset_ += static_cast<std::size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) return Sent::partly;
    return Sent::peer_gone;  // EPIPE, ECONNRESET
  }
  out_.clear();
  out_offset_ = 0;
  return Sent::all;
}

}  // namespace hapticd::daemon::control
