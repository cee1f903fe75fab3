#pragma once
// End-to-end helpers for tests that check the daemon comes through an
// attack unharmed: its file descriptors and memory (/proc), the loop's
// overruns (stats, reset per stretch), and a well-behaved client that keeps
// asking `status` and times every reply.

#include <sys/types.h>

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <thread>
#include <vector>

#include "support.hpp"

namespace hapticd::e2e {

struct ProcessUsage {
  int fds = -1;               ///< entries in /proc/PID/fd
  std::int64_t rss_kib = -1;  ///< VmRSS
};
ProcessUsage usage_of(pid_t pid);
/// usage_of() once the daemon has let go of its clients: waits (up to 10 s)
/// until its descriptors are down to `fds`, then reads.
ProcessUsage settled_usage(const Daemon& d, int fds);

/// stats.reset (write access: the test's uid is the daemon's).
void reset_stats(const Daemon& d);
/// The loop's overruns since the last reset_stats().
std::uint64_t overruns(const Daemon& d);
/// How many overruns an attacked stretch may have against an idle one of the
/// same length: generous, because the host's vCPU stalls come in bursts and
/// CTest runs another test beside this one. A daemon that lets a client
/// disturb its loop overruns every period of the attack, thousands.
inline std::uint64_t generous_bound(std::uint64_t idle) { return 3 * idle + 20; }

struct ProbeResult {
  std::size_t replies = 0;
  std::size_t failures = 0;  ///< no reply within 2 s, an error reply, or the connection lost
  double max_ms = 0.0;
  std::vector<double> ms;
  /// Fraction of replies that came within `limit_ms`.
  double within(double limit_ms) const;
};

/// A client on its own connection asking `status` every 20 ms and timing
/// each reply, from construction to finish().
class Prober {
 public:
  explicit Prober(const std::filesystem::path& socket);
  ~Prober();
  Prober(const Prober&) = delete;
  Prober& operator=(const Prober&) = delete;
  ProbeResult finish();

 private:
  RawConnection connection_;
  std::atomic<bool> stop_{false};
  ProbeResult result_;
  std::thread thread_;
};

}  // namespace hapticd::e2e
