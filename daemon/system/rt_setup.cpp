#include "daemon/system/rt_setup.hpp"

#include <alloca.h>
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <sys/resource.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <system_error>

#include "daemon/system/rt_permission.hpp"

namespace hapticd::daemon::system {
namespace {

constexpr std::size_t page = 4096;
constexpr std::size_t stack_margin = std::size_t{64} * 1024;

std::size_t thread_stack_size() noexcept {
  pthread_attr_t attr;
  std::size_t size = 0;
  if (pthread_getattr_np(pthread_self(), &attr) == 0) {
    pthread_attr_getstacksize(&attr, &size);
    pthread_attr_destroy(&attr);
  }
  return size;
}

// If only the soft RLIMIT_RTPRIO is too low, raise it: an unprivileged
// process may raise its soft limit up to the hard one.
void raise_soft_rtprio(int priority) noexcept {
  rlimit rl{};
  if (::getrlimit(RLIMIT_RTPRIO, &rl) != 0) return;
  const auto want = static_cast<rlim_t>(priority);
  if (rl.rlim_cur != RLIM_INFINITY && rl.rlim_cur < want &&
      (rl.rlim_max == RLIM_INFINITY || rl.rlim_max >= want)) {
    rl.rlim_cur = want;
    ::setrlimit(RLIMIT_RTPRIO, &rl);
  }
}

}  // namespace

__attribute__((noinline)) std::size_t prefault_stack(std::size_t bytes) noexcept {
  const std::size_t stack = thread_stack_size();
  if (stack != 0) bytes = stack > 2 * stack_margin ? std::min(bytes, stack - 2 * stack_margin) : 0;
  if (bytes == 0) return 0;
  auto* p = static_cast<volatile unsigned char*>(alloca(bytes));
  for (std::size_t i = 0; i < bytes; i += page) p[i] = 0;
  p[bytes - 1] = 0;
  return bytes;
}

std::string RtSetupReport::message() const {
  std::string out;
  for (const auto& p : problems) {
    if (!out.empty()) out += '\n';
    out += p;
  }
  return out;
}

RtSetupReport configure_realtime(const RtOptions& o) {
  RtSetupReport r;

  if (o.lock_memory) {
    if (::mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
      r.memory_locked = true;
    } else {
      const int e = errno;
      r.problems.push_back(std::string("mlockall failed (") + std::generic_category().message(e) +
                           "): page faults may stall the RT thread. Grant with: LimitMEMLOCK=infinity in the "
                           "systemd unit, '@group - memlock unlimited' in /etc/security/limits.d/, or "
                           "setcap cap_ipc_lock+ep <hapticd binary>.");
    }
  }

  if (!o.cpus.empty()) {
    cpu_set_t set;
    CPU_ZERO(&set);
    bool valid = true;
    for (int c : o.cpus) {
      if (c < 0 || c >= CPU_SETSIZE)
        valid = false;
      else
        CPU_SET(static_cast<std::size_t>(c), &set);
    }
    const int e = valid ? pthread_setaffinity_np(pthread_self(), sizeof set, &set) : EINVAL;
    if (e == 0) {
      r.affinity_set = true;
    } else {
      std::string list;
      for (int c : o.cpus) list += (list.empty() ? "" : ",") + std::to_string(c);
      r.problems.push_back("CPU affinity {" + list + "} not set (" + std::generic_category().message(e) +
                           "): the CPUs must exist and be in this process's allowed set (see taskset -p, "
                           "the cgroup's cpuset.cpus, or AllowedCPUs= in the unit).");
    }
  }

  if (o.priority != 0) {
    raise_soft_rtprio(o.priority);
    sched_param sp{};
    sp.sched_priority = o.priority;
    const int e = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
    if (e == 0) {
      r.scheduler_set = true;
      r.priority = o.priority;
    } else {
      std::string msg = explain_sched_failure(probe_sched_permission(e, o.priority));
      if (o.require_rt) {
        r.fatal = true;
        msg += " Real time is required (require_rt): not starting.";
      } else {
        msg += " Continuing best-effort under SCHED_OTHER: expect late cycles.";
      }
      r.problems.push_back(std::move(msg));
    }
  }

  if (o.prefault_stack_bytes > 0) {
    r.stack_prefaulted_bytes = prefault_stack(o.prefault_stack_bytes);
    r.stack_prefaulted = r.stack_prefaulted_bytes > 0;
  }

  if (o.hold_dma_latency) {
    std::string err;
    r.dma_latency = CpuDmaLatencyRequest::open(0, &err);
    r.dma_latency_held = r.dma_latency.held();
    if (!r.dma_latency_held) r.problems.push_back(err);
  }
  return r;
}

}  // namespace hapticd::daemon::system
