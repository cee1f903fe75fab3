#pragma once
/// \file
/// Where the hapticd control socket lives. The daemon and every client use the
/// same rule, so `hapticctl` finds the daemon without options.

#include <string>
#include <string_view>

namespace hapticd::client {

/// The configured path if not empty; else $RUNTIME_DIRECTORY/hapticd.sock
/// (set by systemd's RuntimeDirectory=; the first entry if it lists several);
/// else $XDG_RUNTIME_DIR/hapticd.sock; else /tmp/hapticd-<euid>.sock.
std::string resolve_socket_path(std::string_view configured = {});

}  // namespace hapticd::client
