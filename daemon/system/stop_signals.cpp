#include "daemon/system/stop_signals.hpp"

#include <sched.h>
#include <signal.h>

#include <system_error>

#include "daemon/system/thread_placement.hpp"

namespace hapticd::daemon::system {

namespace {

sigset_t stop_set() {
  sigset_t set;
  sigemptyset(&set);
  sigaddset(&set, SIGTERM);
  sigaddset(&set, SIGINT);
  sigaddset(&set, SIGHUP);
  return set;
}

}  // namespace

StopSignals::StopSignals(std::function<void(int)> on_stop) : on_stop_(std::move(on_stop)) {
  const sigset_t set = stop_set();
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
  thread_ = std::thread([this] { run(); });
}

StopSignals::~StopSignals() {
  quit_.store(true, std::memory_order_release);
  // Wakes sigwait() (SIGHUP is ignored, so it changes nothing else).
  pthread_kill(thread_.native_handle(), SIGHUP);
  thread_.join();
}

std::string StopSignals::keep_off_cpu(int cpu) {
  cpu_set_t set;
  CPU_ZERO(&set);
  if (const int e = pthread_getaffinity_np(thread_.native_handle(), sizeof set, &set); e != 0)
    return "cannot read the signal thread's CPU affinity (" + std::generic_category().message(e) + ")";
  if (cpu < 0 || cpu >= CPU_SETSIZE || !CPU_ISSET(static_cast<std::size_t>(cpu), &set)) return {};
  CPU_CLR(static_cast<std::size_t>(cpu), &set);
  if (CPU_COUNT(&set) == 0) return {};  // the loop's CPU is the only one: share it
  if (const int e = pthread_setaffinity_np(thread_.native_handle(), sizeof set, &set); e != 0)
    return "cannot keep the signal thread off CPU " + std::to_string(cpu) + " (" +
           std::generic_category().message(e) + ")";
  return {};
}

const char* StopSignals::name(int signal) noexcept {
  switch (signal) {
    case SIGTERM:
      return "SIGTERM";
    case SIGINT:
      return "SIGINT";
    case SIGHUP:
      return "SIGHUP";
    default:
      return "a signal";
  }
}

void StopSignals::run() noexcept {
  name_this_thread("hapticd-sig");
  const sigset_t set = stop_set();
  while (!quit_.load(std::memory_order_acquire)) {
    int signal = 0;
    if (sigwait(&set, &signal) != 0) continue;
    if (quit_.load(std::memory_order_acquire)) break;
    if (signal == SIGTERM || signal == SIGINT) on_stop_(signal);
  }
}

}  // namespace hapticd::daemon::system
