#include "drivers/skeleton/skeleton_link.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

#include "drivers/device_hooks.hpp"
#include "world/text.hpp"

namespace hapticd::drivers::skeleton {

void SkeletonLink::open(const std::string& path) {
  sockaddr_un address{};
  if (path.size() >= sizeof address.sun_path)
    throw DeviceError("skeleton: socket path " + path + " is longer than " +
                          std::to_string(sizeof address.sun_path - 1) + " bytes",
                      "socket");
  address.sun_family = AF_UNIX;
  std::memcpy(address.sun_path, path.c_str(), path.size() + 1);
  const int fd = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
  if (fd < 0) throw DeviceError("skeleton: socket(): " + world::text::errno_text(errno), "socket");
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    const int error = errno;
    ::close(fd);
    throw DeviceError(
        "skeleton: cannot connect to the peer at " + path + ": " + world::text::errno_text(error), "socket");
  }
  fd_ = fd;
}

void SkeletonLink::close() noexcept {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

LinkOutcome SkeletonLink::exchange(const Request& request, Reply& reply, double timeout_s) noexcept {
  const Frame out = encode(request);
  if (::send(fd_, out.data(), out.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(out.size())) {
    last_errno_ = errno;
    return last_errno_ == EPIPE || last_errno_ == ECONNRESET ? LinkOutcome::closed : LinkOutcome::io_error;
  }
  using Clock = std::chrono::steady_clock;
  const auto deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(timeout_s));
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::microseconds>(deadline - Clock::now()).count();
    if (left <= 0) return LinkOutcome::timeout;
    const timespec wait{static_cast<time_t>(left / 1'000'000), static_cast<long>((left % 1'000'000) * 1000)};
    pollfd p{fd_, POLLIN, 0};
    const int ready = ::ppoll(&p, 1, &wait, nullptr);
    if (ready < 0 && errno == EINTR) continue;
    if (ready < 0) {
      last_errno_ = errno;
      return LinkOutcome::io_error;
    }
    if (ready == 0) return LinkOutcome::timeout;
    std::uint8_t in[frame_size + 1];  // one byte more: a longer datagram is malformed, not truncated
    const ssize_t n = ::recv(fd_, in, sizeof in, MSG_DONTWAIT);
    if (n == 0) return LinkOutcome::closed;
    if (n < 0) {
      if (errno == EAGAIN || errno == EINTR) continue;
      last_errno_ = errno;
      return LinkOutcome::io_error;
    }
    const auto decoded = decode_reply(std::span<const std::uint8_t>(in, static_cast<std::size_t>(n)));
    if (!decoded) return LinkOutcome::malformed;
    if (decoded->sequence == request.sequence) {
      reply = *decoded;
      return LinkOutcome::ok;
    }
    ++stale_replies_;  // the answer to an earlier, timed-out request
  }
}

const char* describe(LinkOutcome outcome) noexcept {
  switch (outcome) {
    case LinkOutcome::ok:
      return "ok";
    case LinkOutcome::timeout:
      return "no reply within the response timeout";
    case LinkOutcome::malformed:
      return "a malformed reply";
    case LinkOutcome::closed:
      return "the peer closed the connection";
    case LinkOutcome::io_error:
      return "a socket error";
  }
  return "?";
}

}  // namespace hapticd::drivers::skeleton
