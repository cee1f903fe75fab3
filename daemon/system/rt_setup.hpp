#pragma once
/// \file
/// Start-up of the RT thread: SCHED_FIFO priority, CPU affinity, locked memory,
/// pre-faulted stack, /dev/cpu_dma_latency held at 0. Call it first thing on
/// the thread that will run the loop (the loop's own std::thread), never from
/// the loop body. Each step is best-effort and reported; without permission
/// for SCHED_FIFO the report carries one message saying why and how to grant
/// it, and `fatal` is set only if the options require real time.

#include <cstddef>
#include <string>
#include <vector>

#include "daemon/system/dma_latency.hpp"

namespace hapticd::daemon::system {

struct RtOptions {
  int priority = 80;        ///< SCHED_FIFO 1..99; 0 = leave the scheduler alone
  std::vector<int> cpus;    ///< affinity; empty = leave unchanged
  bool lock_memory = true;  ///< mlockall(MCL_CURRENT | MCL_FUTURE), process-wide
  std::size_t prefault_stack_bytes = std::size_t{256} * 1024;
  bool hold_dma_latency = true;  ///< /dev/cpu_dma_latency = 0 while the report lives
  bool require_rt = false;       ///< SCHED_FIFO failure is fatal (caller exits non-zero)
};

/// What configure_realtime() achieved. Keep it alive as long as the loop
/// runs: it owns the /dev/cpu_dma_latency request.
struct RtSetupReport {
  bool scheduler_set = false;  ///< SCHED_FIFO at `priority` on the calling thread
  int priority = 0;
  bool affinity_set = false;
  bool memory_locked = false;
  bool stack_prefaulted = false;
  std::size_t stack_prefaulted_bytes = 0;
  bool dma_latency_held = false;
  bool fatal = false;                 ///< require_rt and SCHED_FIFO failed
  std::vector<std::string> problems;  ///< one self-contained message per failed step
  CpuDmaLatencyRequest dma_latency;

  /// All problems joined by newlines (empty if everything asked for worked).
  std::string message() const;
};

/// Configure the calling thread (and mlockall the process). Non-RT, allocates.
RtSetupReport configure_realtime(const RtOptions& options);

/// Touch `bytes` of stack below the caller so the pages are resident (and,
/// after mlockall, locked) before the loop runs. Clipped to the thread's
/// stack size minus a safety margin. Returns the bytes touched.
std::size_t prefault_stack(std::size_t bytes) noexcept;

}  // namespace hapticd::daemon::system
