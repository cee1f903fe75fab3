#pragma once
/// \file
/// Who is on the other end of a connection (SO_PEERCRED) and whether that
/// peer may call write methods (docs/protocol.md, "Access").

#include <string>

#include <sys/types.h>

#include "daemon/control/server.hpp"

namespace hapticd::daemon::control {

/// The peer's pid, uid and gid from SO_PEERCRED; uid and gid are -1 when the
/// kernel does not tell. client_id and can_write are left for the caller.
PeerInfo read_peer_credentials(int socket_fd);

/// Write access: the daemon's effective uid, root, or (when a control group
/// is configured) a member of that group, by primary or supplementary gid.
class WriteAccess {
 public:
  /// group: the control group's name, "" for none. Throws ServerError when
  /// the group does not exist.
  explicit WriteAccess(const std::string& group);

  bool permits(const PeerInfo& peer) const;
  /// The -32001 error for `method` called by `peer`.
  RpcError refusal(const std::string& method, const PeerInfo& peer) const;

  bool has_group() const noexcept { return has_group_; }
  gid_t group_gid() const noexcept { return group_gid_; }
  const std::string& group_name() const noexcept { return group_; }

 private:
  std::string group_;
  bool has_group_ = false;
  gid_t group_gid_ = 0;
  uid_t euid_;
};

}  // namespace hapticd::daemon::control
