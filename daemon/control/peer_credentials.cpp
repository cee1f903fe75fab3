#include "daemon/control/peer_credentials.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>
#include <system_error>
#include <vector>

#include <grp.h>
#include <pwd.h>
#include <sys/socket.h>
#include <unistd.h>

namespace hapticd::daemon::control {

namespace {

/// The group's gid; throws ServerError if it does not exist.
gid_t lookup_group(const std::string& name) {
  std::vector<char> buf(16384);
  group gr{};
  group* result = nullptr;
  int rc = ::getgrnam_r(name.c_str(), &gr, buf.data(), buf.size(), &result);
  if (rc != 0 || result == nullptr) {
    throw ServerError("control socket group '" + name + "' does not exist" +
                      (rc != 0 ? " (getgrnam: " + std::generic_category().message(rc) + ")" : std::string()));
  }
  return gr.gr_gid;
}

/// Supplementary groups of a peer: the "Groups:" line of /proc/<pid>/status
/// when that process still has the peer's uid, else the group database.
std::vector<gid_t> peer_groups(pid_t pid, uid_t uid, gid_t gid) {
  std::vector<gid_t> groups;
  if (pid > 0) {
    std::ifstream status("/proc/" + std::to_string(pid) + "/status");
    std::string line;
    bool uid_matches = false;
    bool have_groups = false;
    while (std::getline(status, line)) {
      std::istringstream fields(line);
      std::string key;
      fields >> key;
      if (key == "Uid:") {
        unsigned long real = 0, effective = 0;
        fields >> real >> effective;
        uid_matches = effective == uid;  // guards against a reused pid
      } else if (key == "Groups:") {
        unsigned long g = 0;
        while (fields >> g) groups.push_back(static_cast<gid_t>(g));
        have_groups = true;
      }
    }
    if (uid_matches && have_groups) return groups;
    groups.clear();
  }
  std::vector<char> buf(16384);
  passwd pw{};
  passwd* result = nullptr;
  if (::getpwuid_r(uid, &pw, buf.data(), buf.size(), &result) != 0 || result == nullptr) return groups;
  int n = 64;
  groups.resize(static_cast<std::size_t>(n));
  if (::getgrouplist(pw.pw_name, gid, groups.data(), &n) < 0) {
    groups.resize(static_cast<std::size_t>(n));
    if (::getgrouplist(pw.pw_name, gid, groups.data(), &n) < 0) n = 0;
  }
  groups.resize(static_cast<std::size_t>(std::max(n, 0)));
  return groups;
}

}  // namespace

PeerInfo read_peer_credentials(int socket_fd) {
  PeerInfo peer;
  ucred cred{};
  socklen_t len = sizeof(cred);
  if (::getsockopt(socket_fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) == 0) {
    peer.pid = cred.pid;
    peer.uid = cred.uid;
    peer.gid = cred.gid;
  } else {
    peer.uid = static_cast<uid_t>(-1);
    peer.gid = static_cast<gid_t>(-1);
  }
  return peer;
}

WriteAccess::WriteAccess(const std::string& group) : group_(group), euid_(::geteuid()) {
  if (!group_.empty()) {
    group_gid_ = lookup_group(group_);
    has_group_ = true;
  }
}

bool WriteAccess::permits(const PeerInfo& peer) const {
  if (peer.uid == euid_ || peer.uid == 0) return true;
  if (!has_group_) return false;
  if (peer.gid == group_gid_) return true;
  auto groups = peer_groups(peer.pid, peer.uid, peer.gid);
  return std::find(groups.begin(), groups.end(), group_gid_) != groups.end();
}

RpcError WriteAccess::refusal(const std::string& method, const PeerInfo& peer) const {
  std::string msg = "'" + method + "' changes the daemon's state: uid " + std::to_string(peer.uid) +
                    " is not the daemon's uid " + std::to_string(euid_) + " nor root";
  if (has_group_) {
    msg += ", and is not a member of group '" + group_ + "' (gid " + std::to_string(group_gid_) + ")";
  } else {
    msg += " (no control group is configured)";
  }
  return RpcError(
      rpc::code::not_permitted, msg,
      nlohmann::json{{"method", method},
                     {"uid", peer.uid},
                     {"required_group", has_group_ ? nlohmann::json(group_) : nlohmann::json(nullptr)}});
}

}  // namespace hapticd::daemon::control
