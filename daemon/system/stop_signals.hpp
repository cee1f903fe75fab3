#pragma once
/// \file
/// The daemon's stop signals, taken from the start. SIGTERM, SIGINT and
/// SIGHUP are blocked in the constructing thread before any other thread
/// exists (every thread inherits the mask), and one thread takes them with
/// sigwait(): SIGTERM and SIGINT call `on_stop` (once each), SIGHUP is
/// ignored. So a stop is seen while the device is being configured, not
/// only once the loop runs (daemon/main.cpp, drivers/stop_request.hpp).

#include <pthread.h>

#include <atomic>
#include <functional>
#include <string>
#include <thread>

namespace hapticd::daemon::system {

class StopSignals {
 public:
  /// `on_stop(signal)` runs on the signal thread; it must not block.
  explicit StopSignals(std::function<void(int signal)> on_stop);
  ~StopSignals();
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

  /// Takes `cpu` (the loop's) out of the signal thread's allowed CPUs, as
  /// run() does for the threads it starts later (thread_placement.hpp).
  /// Returns "" or one line saying what failed.
  std::string keep_off_cpu(int cpu);
  /// "SIGTERM", "SIGINT".
  static const char* name(int signal) noexcept;

 private:
  void run() noexcept;

  std::function<void(int)> on_stop_;
  std::atomic<bool> quit_{false};
  std::thread thread_;
};

}  // namespace hapticd::daemon::system
