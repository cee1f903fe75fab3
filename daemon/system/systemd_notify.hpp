#pragma once
/// \file
/// sd_notify(3) for the daemon's non-RT supervisor thread: READY=1, STATUS=,
/// WATCHDOG=1, STOPPING=1. Why a wrapper: one place that decides "not under
/// systemd" (NOTIFY_SOCKET unset: every call is a no-op that reports it did
/// nothing) and reads the watchdog interval once. The RT thread never calls
/// it: a sendmsg per period is a syscall the RT rules forbid; the supervisor
/// pings only while the loop's cycle counter advances.

#include <chrono>
#include <optional>
#include <string_view>

namespace hapticd::daemon::system {

class SystemdNotifier {
 public:
  /// Reads NOTIFY_SOCKET and the watchdog settings (WATCHDOG_USEC/PID) now.
  SystemdNotifier();

  /// True when NOTIFY_SOCKET is set (we run under systemd with Type=notify).
  bool enabled() const noexcept { return enabled_; }
  /// WATCHDOG_USEC for this process, if the watchdog is on. Ping at half of it.
  std::optional<std::chrono::microseconds> watchdog_interval() const noexcept { return watchdog_; }

  /// Each returns true if a message was sent, false if disabled; throws
  /// std::system_error if sending failed.
  bool ready();
  bool status(std::string_view text);
  bool watchdog_ping();
  bool stopping();

 private:
  bool send(std::string_view state);
  bool enabled_ = false;
  std::optional<std::chrono::microseconds> watchdog_;
};

}  // namespace hapticd::daemon::system
