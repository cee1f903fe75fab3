#include "rt/clock.hpp"

#include <cerrno>
#include <ctime>

namespace hapticd::rt {

Nanos RealClock::now() noexcept {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return Nanos{static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec};
}

void RealClock::sleep_until(Nanos deadline) noexcept {
  const std::int64_t ns = deadline.count();
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(ns / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(ns % 1'000'000'000);
  // clock_nanosleep returns the error number (it does not set errno). With an
  // absolute deadline, retrying after a signal is exactly right.
  while (::clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
}

}  // namespace hapticd::rt
