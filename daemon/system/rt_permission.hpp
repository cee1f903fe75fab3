#pragma once
/// \file
/// Why SCHED_FIFO was refused, told in one message that says how to fix it.
/// EPERM has two common causes that need different fixes: no CAP_SYS_NICE and
/// an RLIMIT_RTPRIO below the priority, or a cgroup whose cpu.rt_runtime_us is
/// 0 (systemd services on kernels with RT group scheduling). Facts are
/// gathered separately from the message so tests can inject them (as root
/// here, SCHED_FIFO just succeeds).

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

namespace hapticd::daemon::system {

struct SchedPermissionFacts {
  int error = 0;  ///< errno of the failed sched call
  int requested_priority = 0;
  bool has_cap_sys_nice = false;
  std::uint64_t rtprio_soft = 0;  ///< RLIMIT_RTPRIO (RLIM_INFINITY mapped to UINT64_MAX)
  std::uint64_t rtprio_hard = 0;
  std::string cgroup_rt_runtime_file;  ///< empty if not found
  std::optional<std::int64_t> cgroup_rt_runtime_us;
};

/// Read capabilities, rlimits and the cgroup RT budget of this process.
SchedPermissionFacts probe_sched_permission(int error, int requested_priority);

/// The one message for the user: what failed, which cause, how to grant it.
std::string explain_sched_failure(const SchedPermissionFacts& facts);

/// Whether the CapEff line of a /proc/<pid>/status text has capability `cap`.
bool status_has_effective_cap(std::string_view proc_status, int cap);

/// The cpu.rt_runtime_us file of the cgroup named in a /proc/self/cgroup text
/// (v1 "N:cpu,cpuacct:/path" or v2 "0::/path"), searched under cgroup_root;
/// falls back to the root of the cpu hierarchy (containers see "/").
std::optional<std::string> find_cgroup_rt_runtime_file(std::string_view proc_self_cgroup,
                                                       const std::string& cgroup_root = "/sys/fs/cgroup");

}  // namespace hapticd::daemon::system
