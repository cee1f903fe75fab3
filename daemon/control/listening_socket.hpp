#pragma once
/// \file
/// The control server's listening Unix socket: created with its mode and
/// group before listen(), a stale file from a crashed daemon replaced, a live
/// daemon's socket never taken over, and removed at close only if the file
/// is still the one created here (docs/protocol.md, "Socket").

#include <optional>
#include <string>

#include <sys/types.h>

namespace hapticd::daemon::control {

class ListeningSocket {
 public:
  ListeningSocket() = default;
  ~ListeningSocket() { close(); }
  ListeningSocket(const ListeningSocket&) = delete;
  ListeningSocket& operator=(const ListeningSocket&) = delete;

  /// Binds and listens on `path` (non-blocking). group: gid to chown the
  /// file to (group_name for messages), none to keep the daemon's. Throws
  /// ServerError naming the path and what failed.
  void open(const std::string& path, mode_t mode, std::optional<gid_t> group, const std::string& group_name);
  /// The next pending connection (non-blocking, close-on-exec), or -1 when
  /// there is none left (or accept failed: reported on stderr).
  int accept_one();
  /// Stops listening and removes the file if it is still ours. Idempotent.
  void close();

  int fd() const noexcept { return fd_; }

 private:
  std::string path_;
  int fd_ = -1;
  ino_t ino_ = 0;
  dev_t dev_ = 0;
};

}  // namespace hapticd::daemon::control
