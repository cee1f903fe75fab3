#include "drivers/stop_request.hpp"

#include <algorithm>
#include <thread>

namespace hapticd::drivers {

void StopRequest::request(const char* why) noexcept {
  // The cause first: whoever sees the stop finds its name.
  const char* expected = nullptr;
  why_.compare_exchange_strong(expected, why, std::memory_order_acq_rel);
  source_.request_stop();
}

SlicedWait::SlicedWait(StopToken stop, Clock::duration timeout)
    : stop_(std::move(stop)), deadline_(Clock::now() + timeout) {}

SlicedWait::Clock::duration SlicedWait::next_slice() const noexcept {
  const Clock::duration left = deadline_ - Clock::now();
  return std::clamp<Clock::duration>(left, Clock::duration::zero(), stop_slice);
}

bool sleep_unless_stopped(const StopToken& stop, std::chrono::steady_clock::duration duration) {
  const SlicedWait wait(stop, duration);
  while (!wait.expired()) {
    if (wait.stopped()) return false;
    std::this_thread::sleep_for(wait.next_slice());
  }
  return !wait.stopped();
}

std::string abandoned(const std::string& what) { return what + ": abandoned, hapticd is stopping"; }

void throw_if_stopped(const StopToken& stop, const std::string& what) {
  if (stop.stop_requested()) throw StopRequested(abandoned(what));
}

}  // namespace hapticd::drivers
