#include "daemon/system/stop_signals.hpp"

#include <signal.h>

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
  const sigset_t set = stop_set();
  while (!quit_.load(std::memory_order_acquire)) {
    int signal = 0;
    if (sigwait(&set, &signal) != 0) continue;
    if (quit_.load(std::memory_order_acquire)) break;
    if (signal == SIGTERM || signal == SIGINT) on_stop_(signal);
  }
}

}  // namespace hapticd::daemon::system
