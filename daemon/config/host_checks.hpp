#pragma once
/// \file
/// What a parsed config names on this host: paths and groups. `hapticd
/// --check-config` and start-up both run these before anything starts, so a
/// config that passes the check does not fail later at bind() or at the
/// first record.start.

#include "daemon/config/config.hpp"

namespace hapticd::daemon::config {

/// Checks, and throws ConfigError at the key's position naming what is
/// accepted:
///  - control.socket (for "", the default path the control server will
///    bind, client::resolve_socket_path): its directory exists and the
///    daemon can create files in it; the path is free or an existing socket
///    (a stale one is replaced at start-up, a live daemon's is refused then);
///  - control.group (when set): the group exists;
///  - the recording directory (resolve_recording_directory): created if
///    missing, as start-up does; it must then be a directory the daemon can
///    create files in;
///  - with [device] origin = "persist", the origin file's directory, the same way.
/// state_directory_env: $STATE_DIRECTORY (nullptr when unset).
void check_host(const DaemonConfig& config, const char* state_directory_env);

}  // namespace hapticd::daemon::config
