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

/// Where the system service listens: /run/hapticd/hapticd.sock, or
/// /run/hapticd/<instance>/hapticd.sock for hapticd@<instance>.service.
std::string service_socket_path(std::string_view instance = {});

/// What a client connects to: `configured` (--socket) if given; else the
/// instance's service socket if `instance` is given; else $HAPTICD_SOCKET if
/// set; else the daemon's own rule (resolve_socket_path) when a socket is
/// there; else the system service's socket when one is there (a user's shell
/// has no $RUNTIME_DIRECTORY); else the daemon's rule, for the error message.
std::string resolve_client_socket_path(std::string_view configured = {}, std::string_view instance = {});

}  // namespace hapticd::client
