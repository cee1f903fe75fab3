#include "daemon/system/systemd_notify.hpp"

#include <systemd/sd-daemon.h>

#include <cstdint>
#include <cstdlib>
#include <string>
#include <system_error>

namespace hapticd::daemon::system {

SystemdNotifier::SystemdNotifier() {
  const char* socket = std::getenv("NOTIFY_SOCKET");  // NOLINT(concurrency-mt-unsafe): no setenv anywhere
  enabled_ = socket != nullptr && *socket != '\0';
  std::uint64_t usec = 0;
  if (sd_watchdog_enabled(0, &usec) > 0 && usec > 0)
    watchdog_ = std::chrono::microseconds(static_cast<std::int64_t>(usec));
}

bool SystemdNotifier::send(std::string_view state) {
  if (!enabled_) return false;
  const std::string s(state);
  const int r = sd_notify(0, s.c_str());
  if (r < 0) throw std::system_error(-r, std::generic_category(), "sd_notify(" + s + ")");
  return r > 0;
}

bool SystemdNotifier::ready() { return send("READY=1"); }
bool SystemdNotifier::watchdog_ping() { return send("WATCHDOG=1"); }
bool SystemdNotifier::stopping() { return send("STOPPING=1"); }
bool SystemdNotifier::status(std::string_view text) {
  std::string s = "STATUS=";
  for (char c : text) s += c == '\n' ? ' ' : c;  // one line: sd_notify is newline-separated
  return send(s);
}

}  // namespace hapticd::daemon::system
