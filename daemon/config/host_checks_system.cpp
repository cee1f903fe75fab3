// hapticd --setup-check: the machine's side (real-time permission, memory
// locking, kernel, CPU isolation, /dev/cpu_dma_latency) and the service
// user's access to a node. daemon/config/host_checks_setup.hpp.

#include <grp.h>
#include <pwd.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <system_error>

#include "daemon/config/host_checks_setup.hpp"
#include "daemon/system/rt_permission.hpp"

namespace hapticd::daemon::config {
namespace {

constexpr int cap_ipc_lock = 14;  // linux/capability.h
constexpr int cap_sys_nice = 23;
constexpr std::uint64_t unlimited = std::numeric_limits<std::uint64_t>::max();

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string trimmed(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  return text;
}

std::string limit_text(std::uint64_t v) { return v == unlimited ? "unlimited" : std::to_string(v); }

std::uint64_t limit_of(rlim_t v) { return v == RLIM_INFINITY ? unlimited : static_cast<std::uint64_t>(v); }

/// "0-1,3" (the kernel's cpulist format) -> {0, 1, 3}; junk is skipped.
std::set<int> parse_cpu_list(const std::string& text) {
  std::set<int> cpus;
  std::stringstream in(text);
  std::string range;
  while (std::getline(in, range, ',')) {
    const std::size_t dash = range.find('-');
    try {
      const int first = std::stoi(range.substr(0, dash));
      const int last = dash == std::string::npos ? first : std::stoi(range.substr(dash + 1));
      for (int c = first; c <= last && c - first < 4096; ++c) cpus.insert(c);
    } catch (const std::exception&) {
    }
  }
  return cpus;
}

/// The CPUs a kernel command-line option names: "isolcpus=domain,2-3" -> {2, 3}.
std::set<int> cmdline_cpus(const std::string& cmdline, const std::string& option) {
  std::stringstream in(cmdline);
  std::string word;
  while (in >> word) {
    if (word.rfind(option + "=", 0) != 0) continue;
    std::string value = word.substr(option.size() + 1);
    // isolcpus flags (nohz, domain, managed_irq) come before the list.
    while (!value.empty() && std::isalpha(static_cast<unsigned char>(value.front())) != 0) {
      const std::size_t comma = value.find(',');
      value = comma == std::string::npos ? "" : value.substr(comma + 1);
    }
    return parse_cpu_list(value);
  }
  return {};
}

bool in_group(const ServiceUser& user, gid_t gid) {
  for (auto g : user.groups)
    if (g == gid) return true;
  return user.gid == gid;
}

std::string owner_text(const struct stat& st) {
  std::string user = std::to_string(st.st_uid);
  std::string group = std::to_string(st.st_gid);
  // NOLINTBEGIN(concurrency-mt-unsafe): the check runs on one thread, before any other starts
  if (const passwd* p = ::getpwuid(st.st_uid); p != nullptr) user = p->pw_name;
  if (const ::group* g = ::getgrgid(st.st_gid); g != nullptr) group = g->gr_name;
  // NOLINTEND(concurrency-mt-unsafe)
  char mode[8];
  std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
  return user + ":" + group + " " + mode;
}

ServiceUser current_user() {
  ServiceUser u;
  u.uid = ::geteuid();
  u.gid = ::getegid();
  // NOLINTNEXTLINE(concurrency-mt-unsafe): one thread, before any other starts
  if (const passwd* p = ::getpwuid(u.uid); p != nullptr) u.name = p->pw_name;
  std::vector<gid_t> groups(static_cast<std::size_t>(std::max(0, ::getgroups(0, nullptr))));
  const int n = ::getgroups(static_cast<int>(groups.size()), groups.data());
  for (int i = 0; i < n; ++i) u.groups.push_back(groups[static_cast<std::size_t>(i)]);
  return u;
}

/// The unit's User=hapticd with its groups, when that user exists.
std::optional<ServiceUser> hapticd_user() {
  const passwd* p = ::getpwnam("hapticd");  // NOLINT(concurrency-mt-unsafe): start-up, one thread
  if (p == nullptr) return std::nullopt;
  ServiceUser u{p->pw_name, p->pw_uid, p->pw_gid, {}};
  int count = 64;
  std::vector<gid_t> groups(static_cast<std::size_t>(count));
  if (::getgrouplist(p->pw_name, p->pw_gid, groups.data(), &count) < 0) {
    groups.resize(static_cast<std::size_t>(count));
    ::getgrouplist(p->pw_name, p->pw_gid, groups.data(), &count);
  }
  for (int i = 0; i < count; ++i) u.groups.push_back(groups[static_cast<std::size_t>(i)]);
  return u;
}

/// Not ok: a fail where it matters now (the service itself, or require_rt),
/// else a warning that says the unit grants it.
Verdict missing_verdict(const DaemonConfig& config, const SetupFacts& facts) {
  return facts.under_systemd || config.loop.require_rt ? Verdict::fail : Verdict::warning;
}

}  // namespace

std::string_view to_string(Verdict verdict) noexcept {
  switch (verdict) {
    case Verdict::ok:
      return "ok";
    case Verdict::warning:
      return "warning";
    case Verdict::fail:
      return "fail";
  }
  return "fail";
}

SetupFacts probe_setup_facts() {
  SetupFacts f;
  const std::string status = read_text("/proc/self/status");
  f.cap_sys_nice = system::status_has_effective_cap(status, cap_sys_nice);
  f.cap_ipc_lock = system::status_has_effective_cap(status, cap_ipc_lock);
  rlimit rl{};
  if (::getrlimit(RLIMIT_RTPRIO, &rl) == 0) {
    f.rtprio_soft = limit_of(rl.rlim_cur);
    f.rtprio_hard = limit_of(rl.rlim_max);
  }
  if (::getrlimit(RLIMIT_MEMLOCK, &rl) == 0) f.memlock_soft = limit_of(rl.rlim_cur);
  f.under_systemd = std::getenv("INVOCATION_ID") != nullptr;  // NOLINT(concurrency-mt-unsafe)
  // Run by hand (root, a developer), the service's user is the unit's.
  const ServiceUser me = current_user();
  const auto service = f.under_systemd ? std::nullopt : hapticd_user();
  f.user = service ? *service : me;
  return f;
}

std::string access_problem(const std::string& path, const ServiceUser& user, int need) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return path + ": " + std::generic_category().message(errno);
  if (user.uid == 0) return {};
  mode_t have = st.st_mode & 07;
  if (st.st_uid == user.uid) {
    have = (st.st_mode >> 6) & 07;
  } else if (in_group(user, st.st_gid)) {
    have = (st.st_mode >> 3) & 07;
  }
  const auto wanted = static_cast<mode_t>(need);
  if ((have & wanted) == wanted) return {};
  const char* what = need == read_write_access ? "read and write" : need == write_access ? "write" : "read";
  return path + " is " + owner_text(st) + ": user " + user.name + " may not " + what + " it";
}

SetupItem check_rt_priority(const DaemonConfig& config, const SetupFacts& facts,
                            const SetupContext& context) {
  SetupItem item{"rt-priority", Verdict::ok, "", ""};
  const auto priority = static_cast<std::uint64_t>(config.loop.priority);
  const bool rlimit_ok = facts.rtprio_soft >= priority || facts.rtprio_hard >= priority;
  system::SchedPermissionFacts sched{
      EPERM, config.loop.priority, facts.cap_sys_nice, facts.rtprio_soft, facts.rtprio_hard,
      "",    std::nullopt};
  if (auto file = system::find_cgroup_rt_runtime_file(read_text(context.proc_root + "/self/cgroup"),
                                                      context.sys_root + "/fs/cgroup")) {
    sched.cgroup_rt_runtime_file = *file;
    try {
      sched.cgroup_rt_runtime_us = std::stoll(read_text(*file));
    } catch (const std::exception&) {
    }
  }
  const bool budget_zero = sched.cgroup_rt_runtime_us && *sched.cgroup_rt_runtime_us == 0;
  if ((facts.cap_sys_nice || rlimit_ok) && !budget_zero) {
    item.finding = "SCHED_FIFO priority " + std::to_string(priority) + " allowed (" +
                   (facts.cap_sys_nice ? std::string("CAP_SYS_NICE")
                                       : "RLIMIT_RTPRIO " + limit_text(facts.rtprio_soft)) +
                   ")";
    return item;
  }
  item.verdict = missing_verdict(config, facts);
  item.finding = system::explain_sched_failure(sched);
  item.fix = budget_zero
                 ? "give the cgroup an RT budget (systemd/hapticd.service.in explains the cgroup trap)"
                 : "run as the service (the unit sets LimitRTPRIO=95 and CAP_SYS_NICE), or by hand: "
                   "'@hapticd - rtprio 95' in /etc/security/limits.d/hapticd.conf";
  if (!facts.under_systemd) item.finding += " (this process, not the service)";
  return item;
}

SetupItem check_memlock(const DaemonConfig& config, const SetupFacts& facts) {
  SetupItem item{"memlock", Verdict::ok, "", ""};
  if (facts.cap_ipc_lock || facts.memlock_soft == unlimited) {
    item.finding = std::string("mlockall() allowed (") +
                   (facts.cap_ipc_lock ? "CAP_IPC_LOCK" : "RLIMIT_MEMLOCK unlimited") + ")";
    return item;
  }
  item.verdict = missing_verdict(config, facts);
  item.finding = "RLIMIT_MEMLOCK is " + limit_text(facts.memlock_soft) +
                 " bytes and no CAP_IPC_LOCK: mlockall() fails, and a page fault in the RT thread can take "
                 "milliseconds" +
                 (facts.under_systemd ? "" : " (this process, not the service)");
  item.fix =
      "run as the service (the unit sets LimitMEMLOCK=infinity and CAP_IPC_LOCK), or by hand: '@hapticd - "
      "memlock unlimited' in /etc/security/limits.d/hapticd.conf";
  return item;
}

SetupItem check_kernel(const DaemonConfig& config, const SetupContext& context) {
  SetupItem item{"kernel", Verdict::ok, "", ""};
  const std::string version = trimmed(read_text(context.proc_root + "/sys/kernel/version"));  // uname -v
  const bool realtime = trimmed(read_text(context.sys_root + "/kernel/realtime")) == "1" ||
                        version.find("PREEMPT_RT") != std::string::npos;
  const double period_us = config.loop.period_s * 1e6;
  if (realtime) {
    item.finding = "PREEMPT_RT kernel (" + version + "): wake-up latency bounded to tens of us";
    return item;
  }
  std::ostringstream s;
  s << "not a PREEMPT_RT kernel (" << (version.empty() ? "uname -v unknown" : version)
    << "): wake-up latency has no bound (a loaded machine wakes the loop milliseconds late); at a "
    << period_us << " us period every wake-up a period late is an overrun";
  if (period_us < 500) s << ", and below 500 us expect them often";
  item.verdict = Verdict::warning;
  item.finding = s.str();
  item.fix = "install Debian's PREEMPT_RT kernel (apt install linux-image-rt-amd64, or -rt-arm64) and reboot";
  return item;
}

SetupItem check_cpu_isolation(const DaemonConfig& config, const SetupContext& context) {
  SetupItem item{"cpu-isolation", Verdict::ok, "", ""};
  const std::string cpu_dir = context.sys_root + "/devices/system/cpu";
  const std::set<int> online = parse_cpu_list(read_text(cpu_dir + "/online"));
  std::set<int> isolated = parse_cpu_list(read_text(cpu_dir + "/isolated"));
  const std::string cmdline = read_text(context.proc_root + "/cmdline");
  for (const char* option : {"isolcpus", "nohz_full"})
    for (int c : cmdline_cpus(cmdline, option)) isolated.insert(c);
  std::string isolated_text;
  for (int c : isolated) isolated_text += (isolated_text.empty() ? "" : ",") + std::to_string(c);
  const int cpu = config.loop.cpu;
  if (cpu >= 0 && !online.empty() && online.count(cpu) == 0) {
    item.verdict = Verdict::fail;
    item.finding = "loop.cpu = " + std::to_string(cpu) +
                   " is not an online CPU here (online: " + trimmed(read_text(cpu_dir + "/online")) + ")";
    item.fix = "set [loop] cpu to an online CPU, best an isolated one";
    return item;
  }
  if (cpu >= 0 && isolated.count(cpu) != 0) {
    item.finding = "the loop runs on CPU " + std::to_string(cpu) + ", isolated (isolcpus/nohz_full)";
    return item;
  }
  item.verdict = Verdict::warning;
  if (cpu < 0) {
    item.finding = "the loop is not pinned ([loop] cpu = -1)" +
                   (isolated.empty() ? std::string(" and no CPU is isolated")
                                     : "; CPUs " + isolated_text + " are isolated");
  } else {
    item.finding = "the loop runs on CPU " + std::to_string(cpu) +
                   ", which is not isolated: other tasks and "
                   "interrupts share it";
  }
  const std::string n =
      cpu >= 0 ? std::to_string(cpu) : (isolated.empty() ? "N" : std::to_string(*isolated.begin()));
  item.fix = "boot with isolcpus=" + n + " nohz_full=" + n + " rcu_nocbs=" + n +
             " and set [loop] cpu = " + n + " (docs/realtime.md)";
  return item;
}

SetupItem check_dma_latency(const SetupFacts& facts, const SetupContext& context) {
  SetupItem item{"cpu-dma-latency", Verdict::ok, "", ""};
  const std::string path = context.dev_root + "/cpu_dma_latency";
  const std::string problem = access_problem(path, facts.user, read_write_access);
  if (problem.empty()) {
    item.finding = path + ": " + facts.user.name + " may hold it (the CPUs stay out of deep idle states)";
    return item;
  }
  item.verdict = Verdict::warning;
  item.finding =
      problem + "; the daemon runs without it (p99 wake-up latency 1.4-1.8 ms instead of 60-380 us here)";
  item.fix =
      "the udev rule 70-hapticd-realtime.rules (in the package; config/ in the tree) gives it to group "
      "hapticd: udevadm trigger --action=add --sysname-match=cpu_dma_latency";
  return item;
}

}  // namespace hapticd::daemon::config
