#include "daemon/system/rt_permission.hpp"

#include <sys/resource.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <system_error>
#include <vector>

namespace hapticd::daemon::system {
namespace {

constexpr int cap_sys_nice = 23;  // linux/capability.h

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string limit_text(std::uint64_t v) {
  return v == std::numeric_limits<std::uint64_t>::max() ? "unlimited" : std::to_string(v);
}

std::vector<std::string_view> split(std::string_view s, char sep) {
  std::vector<std::string_view> out;
  std::size_t start = 0;
  for (;;) {
    const std::size_t pos = s.find(sep, start);
    out.push_back(s.substr(start, pos == std::string_view::npos ? std::string_view::npos : pos - start));
    if (pos == std::string_view::npos) return out;
    start = pos + 1;
  }
}

}  // namespace

bool status_has_effective_cap(std::string_view status, int cap) {
  const std::size_t pos = status.find("CapEff:");
  if (pos == std::string_view::npos) return false;
  std::string hex(status.substr(pos + 7, status.find('\n', pos) - pos - 7));
  try {
    const unsigned long long mask = std::stoull(hex, nullptr, 16);
    return ((mask >> cap) & 1ull) != 0;
  } catch (...) {
    return false;
  }
}

std::optional<std::string> find_cgroup_rt_runtime_file(std::string_view cgroup_text,
                                                       const std::string& root) {
  namespace fs = std::filesystem;
  std::vector<fs::path> candidates;
  for (std::string_view line : split(cgroup_text, '\n')) {
    const auto fields = split(line, ':');
    if (fields.size() < 3) continue;
    const std::string_view controllers = fields[1];
    // The path may itself contain ':'; it is everything after the 2nd colon.
    const std::size_t path_at = fields[0].size() + 1 + controllers.size() + 1;
    std::string path(line.substr(path_at));
    while (!path.empty() && path.front() == '/') path.erase(0, 1);
    if (controllers.empty()) {  // cgroup v2 unified hierarchy
      candidates.push_back(fs::path(root) / path / "cpu.rt_runtime_us");
      candidates.push_back(fs::path(root) / "unified" / path / "cpu.rt_runtime_us");
      continue;
    }
    bool has_cpu = false;
    for (std::string_view c : split(controllers, ','))
      if (c == "cpu") has_cpu = true;
    if (!has_cpu) continue;
    candidates.insert(candidates.begin(),
                      fs::path(root) / std::string(controllers) / path / "cpu.rt_runtime_us");
    candidates.insert(candidates.begin() + 1, fs::path(root) / "cpu" / path / "cpu.rt_runtime_us");
  }
  candidates.push_back(fs::path(root) / "cpu" / "cpu.rt_runtime_us");
  std::error_code ec;
  for (const auto& c : candidates)
    if (fs::is_regular_file(c, ec)) return c.string();
  return std::nullopt;
}

SchedPermissionFacts probe_sched_permission(int error, int requested_priority) {
  SchedPermissionFacts f;
  f.error = error;
  f.requested_priority = requested_priority;
  f.has_cap_sys_nice = status_has_effective_cap(read_text("/proc/self/status"), cap_sys_nice);
  rlimit rl{};
  if (::getrlimit(RLIMIT_RTPRIO, &rl) == 0) {
    f.rtprio_soft = rl.rlim_cur == RLIM_INFINITY ? std::numeric_limits<std::uint64_t>::max() : rl.rlim_cur;
    f.rtprio_hard = rl.rlim_max == RLIM_INFINITY ? std::numeric_limits<std::uint64_t>::max() : rl.rlim_max;
  }
  if (auto file = find_cgroup_rt_runtime_file(read_text("/proc/self/cgroup"))) {
    f.cgroup_rt_runtime_file = *file;
    try {
      f.cgroup_rt_runtime_us = std::stoll(read_text(*file));
    } catch (...) {
    }
  }
  return f;
}

std::string explain_sched_failure(const SchedPermissionFacts& f) {
  std::ostringstream m;
  m << "SCHED_FIFO priority " << f.requested_priority << " refused ("
    << (f.error == EPERM    ? "EPERM"
        : f.error == EINVAL ? "EINVAL"
                            : std::generic_category().message(f.error))
    << "): ";
  if (f.error == EINVAL) {
    m << "the priority must be within 1..99.";
    return m.str();
  }
  if (f.error != EPERM) {
    m << std::generic_category().message(f.error) << '.';
    return m.str();
  }
  const bool rlimit_ok = f.rtprio_soft >= static_cast<std::uint64_t>(f.requested_priority) ||
                         f.rtprio_hard >= static_cast<std::uint64_t>(f.requested_priority);
  if (!f.has_cap_sys_nice && !rlimit_ok) {
    m << "this process has no CAP_SYS_NICE and RLIMIT_RTPRIO is " << limit_text(f.rtprio_soft) << " (hard "
      << limit_text(f.rtprio_hard) << "), below the requested priority. Grant with: "
      << "setcap cap_sys_nice+ep <hapticd binary>, or LimitRTPRIO=95 in the systemd unit, "
      << "or '@group - rtprio 95' in /etc/security/limits.d/ (then log in again).";
    return m.str();
  }
  m << (f.has_cap_sys_nice ? "the process has CAP_SYS_NICE"
                           : "RLIMIT_RTPRIO (" + limit_text(f.rtprio_soft) + ") allows it");
  if (f.cgroup_rt_runtime_us && *f.cgroup_rt_runtime_us == 0) {
    m << ", but its cgroup has no real-time budget: " << f.cgroup_rt_runtime_file
      << " is cpu.rt_runtime_us = 0, so the kernel refuses every RT task in it. Fix: give the cgroup "
      << "(and its parents first) a budget, e.g. echo 950000 > " << f.cgroup_rt_runtime_file
      << ", or keep the service out of the cpu controller (no CPUAccounting=/CPUWeight=/CPUQuota= "
      << "in the unit, or run it in the root cpu cgroup).";
    return m.str();
  }
  m << ", and ";
  if (f.cgroup_rt_runtime_us)
    m << "the cgroup RT budget (" << f.cgroup_rt_runtime_file << " = " << *f.cgroup_rt_runtime_us
      << ") is not 0";
  else
    m << "no cgroup cpu.rt_runtime_us was found";
  m << "; something else forbids it (a container runtime dropping CAP_SYS_NICE, seccomp, SELinux, "
       "or a cgroup v2 cpu controller with RT group scheduling).";
  return m.str();
}

}  // namespace hapticd::daemon::system
