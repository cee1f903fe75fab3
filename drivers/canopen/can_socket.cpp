#include "drivers/canopen/can_socket.hpp"
#include "world/text.hpp"

#include <fcntl.h>
#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <system_error>

namespace hapticd::drivers::canopen {

static_assert(sizeof(can_frame) == 16, "classic struct can_frame is 16 bytes");
static_assert(offsetof(can_frame, data) == 8);

namespace {

constexpr int socket_buffer_bytes = 1 << 20;

using world::text::errno_text;

[[noreturn]] void fail(std::string_view interface, const std::string& what) {
  throw std::runtime_error("CAN interface '" + std::string(interface) + "': " + what);
}

can_frame to_can_frame(const cia301::Frame& f) noexcept {
  can_frame cf{};
  cf.can_id = f.id;
  cf.len = f.len > 8 ? 8 : f.len;
  std::memcpy(cf.data, f.data.data(), 8);
  return cf;
}

void from_can_frame(const can_frame& cf, cia301::Frame& f) noexcept {
  f.id = cf.can_id;
  f.len = cf.len > 8 ? 8 : cf.len;
  std::memcpy(f.data.data(), cf.data, 8);
}

sockaddr_un unix_address(const std::string& path, std::string_view interface) {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  if (path.empty() || path.size() >= sizeof address.sun_path)
    fail(interface,
         "a unix socket path must have 1 to " + std::to_string(sizeof address.sun_path - 1) + " characters");
  std::memcpy(address.sun_path, path.c_str(), path.size() + 1);
  return address;
}

void apply_kernel_filters(int fd, std::span<const CanFilter> filters, std::uint32_t error_classes,
                          std::string_view interface) {
  std::vector<can_filter> kernel;
  for (const CanFilter& f : filters) kernel.push_back({f.id, f.mask});
  // An empty filter list on CAN_RAW_FILTER means "receive nothing"; no option set means everything.
  if (!kernel.empty() && setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, kernel.data(),
                                    static_cast<socklen_t>(kernel.size() * sizeof(can_filter))) != 0)
    fail(interface, "CAN_RAW_FILTER: " + errno_text(errno));
  can_err_mask_t mask = error_classes;
  if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &mask, sizeof mask) != 0)
    fail(interface, "CAN_RAW_ERR_FILTER: " + errno_text(errno));
}

int open_can(std::string_view interface) {
  const std::string name(interface);
  if (name.empty() || name.size() >= IFNAMSIZ) fail(interface, "not a network interface name");
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) {
    const int error = errno;
    if (error == EAFNOSUPPORT || error == EPROTONOSUPPORT)
      fail(interface,
           "this kernel has no AF_CAN raw sockets (modprobe can_raw); the simulated drive uses "
           "interface = \"unix:/path\"");
    fail(interface, "socket(PF_CAN): " + errno_text(error));
  }
  const unsigned index = if_nametoindex(name.c_str());
  if (index == 0) {
    ::close(fd);
    fail(interface, "no such network interface (ip -details link show type can)");
  }
  ifreq request{};
  std::memcpy(request.ifr_name, name.c_str(), name.size() + 1);
  if (ioctl(fd, SIOCGIFFLAGS, &request) == 0 && (request.ifr_flags & IFF_UP) == 0) {
    ::close(fd);
    fail(interface, "the interface is down (ip link set " + name + " up type can bitrate <bit/s>)");
  }
  sockaddr_can address{};
  address.can_family = AF_CAN;
  address.can_ifindex = static_cast<int>(index);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address) != 0) {
    const int error = errno;
    ::close(fd);
    fail(interface, "bind: " + errno_text(error));
  }
  return fd;
}

int open_unix(std::string_view interface, const std::string& path) {
  const sockaddr_un address = unix_address(path, interface);
  const int fd = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
  if (fd < 0) fail(interface, "socket(AF_UNIX, SOCK_SEQPACKET): " + errno_text(errno));
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
    const int error = errno;
    ::close(fd);
    fail(interface, "cannot connect to the simulated bus at " + path + ": " + errno_text(error) +
                        " (start it with hapticd-devsim canopen --listen unix:" + path +
                        ", or a bus of several drives with hapticd-devsim canbus --listen unix:" + path +
                        ")");
  }
  if (::fcntl(fd, F_SETFL, ::fcntl(fd, F_GETFL) | O_NONBLOCK) != 0) {
    const int error = errno;
    ::close(fd);
    fail(interface, "O_NONBLOCK: " + errno_text(error));
  }
  return fd;
}

}  // namespace

CanFilter exact_standard_filter(std::uint32_t id) noexcept {
  return {id & CAN_SFF_MASK, CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG};
}

std::string_view unix_path_of(std::string_view interface) noexcept {
  constexpr std::string_view prefix = "unix:";
  return interface.substr(0, prefix.size()) == prefix ? interface.substr(prefix.size()) : std::string_view{};
}

CanSocket::~CanSocket() { close(); }

CanSocket::CanSocket(CanSocket&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)),
      unix_(other.unix_),
      last_errno_(other.last_errno_),
      malformed_(other.malformed_),
      filters_(std::move(other.filters_)),
      error_classes_(other.error_classes_) {}

CanSocket& CanSocket::operator=(CanSocket&& other) noexcept {
  if (this != &other) {
    close();
    fd_ = std::exchange(other.fd_, -1);
    unix_ = other.unix_;
    last_errno_ = other.last_errno_;
    malformed_ = other.malformed_;
    filters_ = std::move(other.filters_);
    error_classes_ = other.error_classes_;
  }
  return *this;
}

CanSocket CanSocket::open(std::string_view interface, std::span<const CanFilter> filters,
                          std::uint32_t error_classes) {
  const std::string_view path = unix_path_of(interface);
  const bool is_unix = !path.empty() || interface == "unix:";
  CanSocket result(is_unix ? open_unix(interface, std::string(path)) : open_can(interface), is_unix);
  // Larger buffers ride out a stall of either side without losing frames:
  // receive, a stalled RT loop (TPDOs, EMCYs wait); send, on the unix seam a
  // stalled peer (a connected AF_UNIX socket's frames count against the
  // sender's SO_SNDBUF until the peer reads them; on CAN the qdisc's
  // txqueuelen limits what waits for the wire).
  const int bytes = socket_buffer_bytes;
  (void)setsockopt(result.fd_, SOL_SOCKET, SO_RCVBUF, &bytes, sizeof bytes);
  (void)setsockopt(result.fd_, SOL_SOCKET, SO_SNDBUF, &bytes, sizeof bytes);
  result.set_filters(filters, error_classes);
  return result;
}

std::pair<CanSocket, CanSocket> CanSocket::pair() {
  int fds[2];
  if (::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0, fds) != 0)
    throw std::runtime_error("socketpair(AF_UNIX, SOCK_SEQPACKET): " + errno_text(errno));
  return {CanSocket(fds[0], true), CanSocket(fds[1], true)};
}

void CanSocket::set_filters(std::span<const CanFilter> filters, std::uint32_t error_classes) {
  filters_.assign(filters.begin(), filters.end());
  error_classes_ = error_classes;
  if (!unix_ && fd_ >= 0) apply_kernel_filters(fd_, filters, error_classes, "fd " + std::to_string(fd_));
}

bool CanSocket::passes(const cia301::Frame& frame) const noexcept {
  if ((frame.id & CAN_ERR_FLAG) != 0) return (frame.id & error_classes_ & CAN_ERR_MASK) != 0;
  if (filters_.empty()) return true;
  for (const CanFilter& f : filters_)
    if ((frame.id & f.mask) == (f.id & f.mask)) return true;
  return false;
}

IoStatus CanSocket::send(const cia301::Frame& frame) noexcept {
  const can_frame cf = to_can_frame(frame);
  const ssize_t n = ::send(fd_, &cf, sizeof cf, MSG_DONTWAIT | MSG_NOSIGNAL);
  if (n == static_cast<ssize_t>(sizeof cf)) return IoStatus::ok;
  last_errno_ = n < 0 ? errno : EMSGSIZE;
  if (last_errno_ == EAGAIN || last_errno_ == EWOULDBLOCK || last_errno_ == ENOBUFS)
    return IoStatus::would_block;
  if (last_errno_ == EPIPE || last_errno_ == ECONNRESET || last_errno_ == ENOTCONN) return IoStatus::closed;
  return IoStatus::error;
}

IoStatus CanSocket::receive(cia301::Frame& frame) noexcept {
  // A buffer larger than any frame, and MSG_TRUNC for the real length: a
  // message of another size is seen as what it is, never cut to 16 bytes.
  // No allocation: the buffer is on the stack.
  for (;;) {
    alignas(canfd_frame) unsigned char buffer[sizeof(canfd_frame)];
    iovec io{buffer, sizeof buffer};
    msghdr message{};
    message.msg_iov = &io;
    message.msg_iovlen = 1;
    const ssize_t n = ::recvmsg(fd_, &message, MSG_DONTWAIT | MSG_TRUNC);
    if (n < 0) {
      last_errno_ = errno;
      if (last_errno_ == EAGAIN || last_errno_ == EWOULDBLOCK) return IoStatus::would_block;
      if (last_errno_ == EINTR) continue;
      if (last_errno_ == ECONNRESET || last_errno_ == ENOTCONN) return IoStatus::closed;
      return IoStatus::error;
    }
    // SEQPACKET end of stream and an empty message both read 0 bytes: only a
    // peer that hung up is the end.
    if (n == 0 && unix_ && peer_hung_up()) return IoStatus::closed;
    can_frame cf{};
    if (n == static_cast<ssize_t>(sizeof cf)) std::memcpy(&cf, buffer, sizeof cf);
    if (n != static_cast<ssize_t>(sizeof cf) || cf.len > CAN_MAX_DLEN) {
      malformed_ = MalformedMessage{};
      malformed_.bytes = static_cast<std::uint32_t>(n);
      malformed_.truncated = (message.msg_flags & MSG_TRUNC) != 0 && n <= static_cast<ssize_t>(sizeof buffer);
      if (n == static_cast<ssize_t>(sizeof cf)) {
        malformed_.can_id = cf.can_id;
        malformed_.can_len = cf.len;
      }
      return IoStatus::malformed;
    }
    from_can_frame(cf, frame);
    if (!unix_ || passes(frame)) return IoStatus::ok;
  }
}

bool CanSocket::peer_hung_up() const noexcept {
  pollfd p{fd_, POLLRDHUP, 0};
  return ::poll(&p, 1, 0) > 0 && (p.revents & (POLLRDHUP | POLLHUP)) != 0;
}

bool CanSocket::wait_readable(std::chrono::microseconds timeout) const {
  pollfd p{fd_, POLLIN, 0};
  const auto ms = std::chrono::ceil<std::chrono::milliseconds>(timeout).count();
  const int ready = ::poll(&p, 1, static_cast<int>(ms < 0 ? 0 : ms));
  return ready > 0;
}

void CanSocket::close() noexcept {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

CanListener::~CanListener() { close(); }

CanListener::CanListener(CanListener&& other) noexcept
    : fd_(std::exchange(other.fd_, -1)), path_(std::move(other.path_)) {}

CanListener& CanListener::operator=(CanListener&& other) noexcept {
  if (this != &other) {
    close();
    fd_ = std::exchange(other.fd_, -1);
    path_ = std::move(other.path_);
  }
  return *this;
}

CanListener CanListener::listen(const std::string& path, int backlog) {
  const std::string label = "unix:" + path;
  const sockaddr_un address = unix_address(path, label);
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode)) fail(label, path + " exists and is not a socket; not replacing it");
    ::unlink(path.c_str());
  }
  CanListener listener;
  listener.fd_ = ::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (listener.fd_ < 0) fail(label, "socket: " + errno_text(errno));
  if (::bind(listener.fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0)
    fail(label, "bind: " + errno_text(errno));
  listener.path_ = path;
  if (::listen(listener.fd_, backlog) != 0) fail(label, "listen: " + errno_text(errno));
  return listener;
}

CanSocket CanListener::accept(std::chrono::microseconds timeout) {
  pollfd p{fd_, POLLIN, 0};
  const auto ms = std::chrono::ceil<std::chrono::milliseconds>(timeout).count();
  if (::poll(&p, 1, static_cast<int>(ms < 0 ? 0 : ms)) <= 0) return {};
  const int fd = ::accept4(fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
  if (fd < 0) return {};
  const int bytes = socket_buffer_bytes;
  (void)setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &bytes, sizeof bytes);
  (void)setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &bytes, sizeof bytes);
  return CanSocket(fd, true);
}

void CanListener::close() noexcept {
  if (fd_ >= 0) {
    ::close(fd_);
    if (!path_.empty()) ::unlink(path_.c_str());
  }
  fd_ = -1;
}

}  // namespace hapticd::drivers::canopen
