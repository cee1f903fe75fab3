#include "daemon/control/listening_socket.hpp"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <system_error>

#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include "daemon/control/server.hpp"
#include "world/text.hpp"

namespace hapticd::daemon::control {

namespace {
using world::text::errno_text;

/// A socket file left by a daemon that is gone is removed; one where a
/// daemon answers, or anything that is not a socket, stops start-up.
void remove_stale_socket(const std::string& path, const sockaddr* address, socklen_t address_size) {
  struct stat st {};
  if (::lstat(path.c_str(), &st) != 0) return;
  if (!S_ISSOCK(st.st_mode)) {
    throw ServerError("control socket path '" + path + "' exists and is not a socket; not removing it");
  }
  int probe = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (probe < 0) throw ServerError("socket: " + errno_text(errno));
  int rc = ::connect(probe, address, address_size);
  int e = errno;
  ::close(probe);
  if (rc == 0) {
    throw ServerError("another hapticd is already running on " + path +
                      " (it answered a connect); stop it first");
  }
  if (e != ECONNREFUSED) {
    throw ServerError("cannot tell whether " + path + " is in use (connect: " + errno_text(e) + ")");
  }
  if (::unlink(path.c_str()) != 0 && errno != ENOENT) {
    throw ServerError("cannot remove stale socket " + path + ": " + errno_text(errno));
  }
}
}  // namespace

void ListeningSocket::open(const std::string& path, mode_t mode, std::optional<gid_t> group,
                           const std::string& group_name) {
  close();
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.size() >= sizeof(addr.sun_path)) {
    throw ServerError("control socket path '" + path + "' is longer than " +
                      std::to_string(sizeof(addr.sun_path) - 1) + " bytes");
  }
  std::memcpy(addr.sun_path, path.data(), path.size());
  const auto* sa = reinterpret_cast<const sockaddr*>(&addr);
  remove_stale_socket(path, sa, sizeof(addr));

  path_ = path;
  fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
  if (fd_ < 0) throw ServerError("socket: " + errno_text(errno));
  if (::bind(fd_, sa, sizeof(addr)) != 0) {
    throw ServerError("cannot bind control socket " + path + ": " + errno_text(errno));
  }
  if (struct stat st{}; ::lstat(path.c_str(), &st) == 0) {
    ino_ = st.st_ino;
    dev_ = st.st_dev;
  }
  // Mode and group before listen(): until then nobody can connect.
  if (::chmod(path.c_str(), mode) != 0) {
    throw ServerError("cannot chmod control socket " + path + ": " + errno_text(errno));
  }
  if (group && ::chown(path.c_str(), static_cast<uid_t>(-1), *group) != 0) {
    throw ServerError("cannot give control socket " + path + " to group '" + group_name +
                      "': " + errno_text(errno));
  }
  if (::listen(fd_, 64) != 0) throw ServerError("listen on " + path + ": " + errno_text(errno));
}

int ListeningSocket::accept_one() {
  for (;;) {
    int fd = ::accept4(fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd >= 0) return fd;
    if (errno == EINTR || errno == ECONNABORTED) continue;
    if (errno != EAGAIN && errno != EWOULDBLOCK) {
      std::fprintf(stderr, "hapticd: control: accept: %s\n", errno_text(errno).c_str());
    }
    return -1;
  }
}

void ListeningSocket::close() {
  if (fd_ < 0) return;
  ::close(fd_);
  fd_ = -1;
  // Remove the socket only if it is still ours.
  struct stat st {};
  if (::lstat(path_.c_str(), &st) == 0 && st.st_ino == ino_ && st.st_dev == dev_) {
    ::unlink(path_.c_str());
  }
}

}  // namespace hapticd::daemon::control
