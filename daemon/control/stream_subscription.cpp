#include "daemon/control/stream_subscription.hpp"

#include <cerrno>
#include <cmath>
#include <system_error>

#include <sys/timerfd.h>
#include <unistd.h>

#include "rpc/jsonrpc.hpp"

namespace hapticd::daemon::control {

bool StreamSubscription::start(std::uint64_t number, double rate_hz, std::vector<std::string> channels) {
  bool created = false;
  if (timer_fd_ < 0) {
    timer_fd_ = ::timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
    if (timer_fd_ < 0) {
      throw rpc::RpcError(rpc::code::busy,
                          "cannot create a stream timer: " + std::generic_category().message(errno));
    }
    created = true;
  }
  auto period_ns = static_cast<long long>(std::llround(1e9 / rate_hz));
  if (period_ns < 1) period_ns = 1;
  itimerspec spec{};
  spec.it_interval.tv_sec = static_cast<time_t>(period_ns / 1'000'000'000);
  spec.it_interval.tv_nsec = static_cast<long>(period_ns % 1'000'000'000);
  spec.it_value = spec.it_interval;
  ::timerfd_settime(timer_fd_, 0, &spec, nullptr);
  number_ = number;
  channels_ = std::move(channels);
  rate_hz_ = rate_hz;
  seq = 0;
  dropped = 0;
  return created;
}

void StreamSubscription::stop() {
  if (timer_fd_ < 0) return;
  ::close(timer_fd_);
  timer_fd_ = -1;
  number_ = 0;
}

std::uint64_t StreamSubscription::take_expirations() {
  std::uint64_t expirations = 0;
  if (::read(timer_fd_, &expirations, sizeof(expirations)) != static_cast<ssize_t>(sizeof(expirations)))
    return 0;
  return expirations;
}

}  // namespace hapticd::daemon::control
