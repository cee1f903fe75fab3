#pragma once
/// \file
/// Where a daemon thread runs and what it is called. The RT loop pins itself
/// (rt_setup); the control and recorder threads are pinned by whoever starts
/// them, so a config can keep them off the RT CPU ([control] cpu, [recorder]
/// cpu). Names show in ps -L, top -H and /proc/PID/task/*/comm, which is how
/// the tests find the RT thread. Header-only: the control server and the
/// recorder use it without linking the rest of daemon/system.

#include <pthread.h>
#include <sched.h>

#include <cerrno>
#include <string>
#include <system_error>
#include <vector>

namespace hapticd::daemon::system {

/// Pins `thread` to `cpus` (empty: leaves it where it is). Returns "" or one
/// line saying what failed and why.
inline std::string pin_thread(pthread_t thread, const std::vector<int>& cpus) {
  if (cpus.empty()) return {};
  cpu_set_t set;
  CPU_ZERO(&set);
  std::string list;
  bool valid = true;
  for (const int c : cpus) {
    list += (list.empty() ? "" : ",") + std::to_string(c);
    if (c < 0 || c >= CPU_SETSIZE) {
      valid = false;
    } else {
      CPU_SET(static_cast<std::size_t>(c), &set);
    }
  }
  const int e = valid ? pthread_setaffinity_np(thread, sizeof set, &set) : EINVAL;
  if (e == 0) return {};
  return "CPU affinity {" + list + "} not set (" + std::generic_category().message(e) +
         "): the CPUs must exist and be in this process's allowed set (taskset -p, cpuset.cpus, "
         "AllowedCPUs=)";
}

/// Takes `cpu` out of the calling thread's allowed CPUs, so that the threads
/// it creates from now on stay off it too (they inherit the mask), unless
/// that would leave none. Returns "" or one line saying what failed.
inline std::string keep_off_cpu(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (const int e = pthread_getaffinity_np(pthread_self(), sizeof set, &set); e != 0)
    return "cannot read the CPU affinity (" + std::generic_category().message(e) + ")";
  if (cpu < 0 || cpu >= CPU_SETSIZE || !CPU_ISSET(static_cast<std::size_t>(cpu), &set)) return {};
  CPU_CLR(static_cast<std::size_t>(cpu), &set);
  if (CPU_COUNT(&set) == 0) return {};  // the loop's CPU is the only one: share it
  if (const int e = pthread_setaffinity_np(pthread_self(), sizeof set, &set); e != 0)
    return "cannot keep off CPU " + std::to_string(cpu) + " (" + std::generic_category().message(e) + ")";
  return {};
}

/// Names the calling thread; at most 15 bytes are kept.
inline void name_this_thread(const char* name) noexcept { pthread_setname_np(pthread_self(), name); }

}  // namespace hapticd::daemon::system
