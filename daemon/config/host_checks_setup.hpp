#pragma once
/// \file
/// `hapticd --setup-check`: is this machine ready to run this config? Each
/// item gets a verdict and, when not ok, the fix: real-time permission and
/// memory locking, the kernel (PREEMPT_RT or not, and what that means for
/// the period), CPU isolation, /dev/cpu_dma_latency, the device present and
/// accessible to the service user, the period against the driver's link
/// budget, the control socket and the recording directory. Nothing here
/// opens the bus (`--check-config` does). Every file is read under the roots
/// of SetupContext, so the tests run each check on a fake /proc, /sys and
/// /dev tree; what a process has (limits, capabilities) is in SetupFacts.

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/config/config.hpp"

namespace hapticd::daemon::config {

enum class Verdict { ok, warning, fail };
std::string_view to_string(Verdict verdict) noexcept;  ///< "ok", "warning", "fail"

struct SetupItem {
  std::string name;  ///< "rt-priority", "kernel", "device" ...
  Verdict verdict = Verdict::ok;
  std::string finding;  ///< what was found, with the figures
  std::string fix;      ///< how to make it ok ("" when ok)
};

/// Who the daemon runs as: the unit's User=hapticd when that user exists,
/// else whoever runs the check.
struct ServiceUser {
  std::string name;
  std::uint32_t uid = 0;
  std::uint32_t gid = 0;
  std::vector<std::uint32_t> groups;  ///< supplementary, with gid
};

/// What this process has (probe_setup_facts(); tests make their own).
struct SetupFacts {
  bool cap_sys_nice = false;
  bool cap_ipc_lock = false;
  std::uint64_t rtprio_soft = 0;  ///< RLIMIT_RTPRIO, UINT64_MAX for unlimited
  std::uint64_t rtprio_hard = 0;
  std::uint64_t memlock_soft = 0;  ///< RLIMIT_MEMLOCK in bytes, UINT64_MAX for unlimited
  bool under_systemd = false;      ///< $INVOCATION_ID: started by systemd (the unit's limits apply)
  ServiceUser user;
};

struct SetupContext {
  std::string proc_root = "/proc";
  std::string sys_root = "/sys";
  std::string dev_root = "/dev";
  /// `ip -details -json link show dev NAME` (iproute2): the interface's
  /// netlink details, for the CAN bit rate sysfs does not show. nullopt
  /// when it cannot be run.
  std::function<std::optional<std::string>(const std::string& interface)> ip_details;
  /// $STATE_DIRECTORY (nullptr: unset).
  const char* state_directory_env = nullptr;
};

/// The facts of this process; the service user as above.
SetupFacts probe_setup_facts();
/// The real ip_details (runs `ip`).
std::optional<std::string> run_ip_details(const std::string& interface);

// The checks, one item each (tests call them one by one).
SetupItem check_rt_priority(const DaemonConfig& config, const SetupFacts& facts, const SetupContext& context);
SetupItem check_memlock(const DaemonConfig& config, const SetupFacts& facts);
SetupItem check_kernel(const DaemonConfig& config, const SetupContext& context);
SetupItem check_cpu_isolation(const DaemonConfig& config, const SetupContext& context);
SetupItem check_dma_latency(const SetupFacts& facts, const SetupContext& context);
SetupItem check_paths(const DaemonConfig& config, const SetupContext& context);
/// The device the config names: present, accessible to the service user
/// (and, for CAN, up at the configured bit rate), then the period against
/// the driver's budget. One or two items.
std::vector<SetupItem> check_device(const DaemonConfig& config, const SetupFacts& facts,
                                    const SetupContext& context);

/// Every check above, in that order.
std::vector<SetupItem> run_setup_check(const DaemonConfig& config, const SetupFacts& facts,
                                       const SetupContext& context);

/// The worst verdict (ok for none).
Verdict overall(const std::vector<SetupItem>& items) noexcept;
/// {"config", "service_user", "verdict", "counts": {ok, warning, fail}, "items": [...]}.
nlohmann::json to_json(const DaemonConfig& config, const SetupFacts& facts,
                       const std::vector<SetupItem>& items);
/// The same for a person: one line per item, its fix below, counts last.
std::string to_text(const DaemonConfig& config, const SetupFacts& facts, const std::vector<SetupItem>& items);

/// What access_problem() asks for: read (4), write (2), or both (6), as in a mode.
inline constexpr int read_access = 04;
inline constexpr int write_access = 02;
inline constexpr int read_write_access = 06;
/// Whether `user` may open `path` with `need`: its mode, owner and group
/// against the user's uid and groups (root may). "" if it may, else why not
/// ("/dev/x is root:root 0600: user hapticd may not read and write it").
std::string access_problem(const std::string& path, const ServiceUser& user, int need);

}  // namespace hapticd::daemon::config
