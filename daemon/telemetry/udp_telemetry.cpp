#include "daemon/telemetry/udp_telemetry.hpp"

#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <system_error>
#include <utility>

#include "daemon/system/thread_placement.hpp"
#include "daemon/telemetry/datagram.hpp"

namespace hapticd::daemon::telemetry {

namespace {

using Clock = std::chrono::steady_clock;
/// A partial batch waits at most this long for its other samples.
constexpr auto batch_patience = std::chrono::milliseconds(250);

std::size_t power_of_two_at_least(std::size_t n) {
  std::size_t p = 2;
  while (p < n) p <<= 1;
  return p;
}

std::uint64_t decimation_for(double rate_hz, double period_s) {
  const double n = std::round(1.0 / (rate_hz * period_s));
  return n >= 1.0 ? static_cast<std::uint64_t>(n) : 1;
}

int open_socket(const UdpEndpoint& to) {
  const int fd = ::socket(to.address.ss_family, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd < 0) throw TelemetryError("cannot open a UDP socket: " + std::generic_category().message(errno));
  // Connected, so the kernel reports an ICMP port-unreachable as
  // ECONNREFUSED on a later send (an unconnected socket never says).
  if (::connect(fd, reinterpret_cast<const sockaddr*>(&to.address), to.length) != 0) {
    const int error = errno;
    ::close(fd);
    throw TelemetryError("cannot address " + to.text + ": " + std::generic_category().message(error));
  }
  return fd;
}

}  // namespace

/// What the sender thread owns.
struct UdpTelemetry::SenderState {
  int fd = -1;
  std::uint64_t generation = 0;
  std::uint32_t batch = 1;
  std::string prefix;
  std::vector<std::string> channels;
  Layout previous, current;
  std::uint64_t first_cycle = 0;  ///< `current` from this cycle on
  std::string datagram;
  std::uint32_t in_datagram = 0;
  Clock::time_point oldest{};
  Counters counts;  ///< published to counters_ once per turn
};

UdpTelemetry::UdpTelemetry(double period_s, std::size_t queue_capacity)
    : period_s_(period_s),
      period_ns_(std::llround(period_s * 1e9)),
      queue_(power_of_two_at_least(queue_capacity)) {
  thread_ = std::thread([this] { run(); });
}

UdpTelemetry::~UdpTelemetry() { stop(); }

void UdpTelemetry::stop() {
  {
    std::lock_guard lock(mutex_);
    quit_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  std::lock_guard lock(mutex_);
  if (next_fd_ >= 0) ::close(next_fd_);
  next_fd_ = -1;
}

void UdpTelemetry::apply(const Settings& settings) {
  bool address_changed = false;
  {
    std::lock_guard lock(mutex_);
    address_changed = !(settings.udp == settings_.udp);
  }
  // Opened here, on the caller's thread, so a failure is the caller's answer.
  const int fd = address_changed && settings.udp ? open_socket(*settings.udp) : -1;
  {
    std::lock_guard lock(mutex_);
    if (address_changed) {
      if (next_fd_ >= 0) ::close(next_fd_);
      next_fd_ = fd;
      fd_changed_ = true;
    }
    settings_ = settings;
    ++generation_;
    decimation_.store(decimation_for(settings.rate_hz, period_s_), std::memory_order_relaxed);
    enabled_.store(settings.enabled && settings.udp.has_value(), std::memory_order_relaxed);
  }
  wake_.notify_all();
}

Settings UdpTelemetry::settings() const {
  std::lock_guard lock(mutex_);
  return settings_;
}

void UdpTelemetry::set_scene(std::vector<std::string> scene_channels, std::uint64_t first_cycle) {
  {
    std::lock_guard lock(mutex_);
    scene_previous_ = std::move(scene_current_);
    scene_current_ = std::move(scene_channels);
    scene_first_cycle_ = first_cycle;
    hold_until_ = {};
    ++generation_;
  }
  wake_.notify_all();
}

void UdpTelemetry::hold_for_scene() {
  std::lock_guard lock(mutex_);
  hold_until_ = Clock::now() + std::chrono::seconds(3);
}

void UdpTelemetry::offer(std::span<const TelemetrySample> batch) noexcept {
  if (!enabled_.load(std::memory_order_relaxed)) return;
  const std::uint64_t every = decimation_.load(std::memory_order_relaxed);
  std::uint64_t queued = 0;
  for (const auto& sample : batch) {
    if (sample.cycle % every == 0 && queue_.try_push(sample)) ++queued;
  }
  if (queued == 0) return;
  queued_.store(queued_.load(std::memory_order_relaxed) + queued, std::memory_order_relaxed);
  wake_.notify_one();
}

Counters UdpTelemetry::counters() const {
  std::lock_guard lock(mutex_);
  Counters out = counters_;
  out.samples_queued = queued_.load(std::memory_order_relaxed);
  out.dropped_queue = queue_.dropped();
  return out;
}

/// Publishes the counts; takes new settings or a new scene, if any, after
/// sending the partial datagram made under the old ones.
void UdpTelemetry::refresh(SenderState& s) {
  {
    std::lock_guard lock(mutex_);
    counters_ = s.counts;
    if (s.generation == generation_) return;
  }
  send_datagram(s);
  std::lock_guard lock(mutex_);
  s.generation = generation_;
  if (fd_changed_) {
    if (s.fd >= 0) ::close(s.fd);
    s.fd = next_fd_;
    next_fd_ = -1;
    fd_changed_ = false;
  }
  s.batch = settings_.batch;
  s.prefix = settings_.prefix;
  s.channels = settings_.channels;
  s.previous = make_layout(s.channels, scene_previous_);
  s.current = make_layout(s.channels, scene_current_);
  s.first_cycle = scene_first_cycle_;
}

void UdpTelemetry::send_datagram(SenderState& s) {
  if (s.in_datagram == 0) return;
  if (s.batch > 1) s.datagram += ']';
  const auto n =
      s.fd >= 0 ? ::send(s.fd, s.datagram.data(), s.datagram.size(), MSG_DONTWAIT | MSG_NOSIGNAL) : -1;
  if (n == static_cast<ssize_t>(s.datagram.size())) {
    ++s.counts.datagrams_sent;
    s.counts.samples_sent += s.in_datagram;
  } else {
    const int error = s.fd < 0 ? ENOTCONN : errno;
    ++s.counts.datagrams_dropped;
    s.counts.samples_dropped_send += s.in_datagram;
    if (error == EAGAIN || error == EWOULDBLOCK || error == ENOBUFS) {
      ++s.counts.buffer_full;
      s.counts.last_error = "socket buffer full";
    } else if (error == ECONNREFUSED) {
      ++s.counts.refused;
      s.counts.last_error = "port unreachable (nobody listens there)";
    } else {
      s.counts.last_error = std::generic_category().message(error);
    }
  }
  s.datagram.clear();
  s.in_datagram = 0;
}

void UdpTelemetry::format(SenderState& s, const TelemetrySample& sample) {
  const Layout& layout = sample.cycle >= s.first_cycle ? s.current : s.previous;
  std::string object;
  append_object(object, sample, layout, s.prefix, period_ns_, s.counts.non_finite);
  // Room for the object, its separator and the closing bracket.
  if (s.in_datagram > 0 && s.datagram.size() + object.size() + 2 > max_datagram_bytes) send_datagram(s);
  if (s.in_datagram == 0) {
    s.oldest = Clock::now();
    if (s.batch > 1) s.datagram += '[';
  } else {
    s.datagram += ',';
  }
  s.datagram += object;
  ++s.in_datagram;
  if (s.in_datagram >= s.batch) send_datagram(s);
}

bool UdpTelemetry::held() const {
  std::lock_guard lock(mutex_);
  return !quit_ && Clock::now() < hold_until_;
}

void UdpTelemetry::run() {
  // Placed like the daemon's other non-RT threads: off the loop's CPU.
  system::name_this_thread("hapticd-udp");
  SenderState s;
  std::vector<TelemetrySample> chunk(256);
  std::vector<TelemetrySample> popped;  ///< taken from the queue, not yet formatted
  popped.reserve(queue_.capacity());
  for (;;) {
    bool quit = false;
    {
      std::unique_lock lock(mutex_);
      wake_.wait_for(lock, std::chrono::milliseconds(50),
                     [&] { return quit_ || !queue_.empty() || s.generation != generation_; });
      quit = quit_;
    }
    // Pop first, then read the settings: every sample popped was offered
    // after any apply() that returned before, so it gets those settings
    // (or newer). While held for a scene switch the samples stay queued.
    if (!held()) {
      std::size_t n = 0;
      do {
        n = queue_.pop_bulk(std::span<TelemetrySample>(chunk));
        popped.insert(popped.end(), chunk.begin(), chunk.begin() + static_cast<std::ptrdiff_t>(n));
      } while (n == chunk.size() && popped.size() < queue_.capacity());
    }
    refresh(s);
    if (held()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      continue;
    }
    for (const auto& sample : popped) format(s, sample);
    popped.clear();
    if (s.in_datagram > 0 && (quit || Clock::now() - s.oldest >= batch_patience)) send_datagram(s);
    if (quit && queue_.empty()) break;
  }
  {
    std::lock_guard lock(mutex_);
    counters_ = s.counts;
  }
  if (s.fd >= 0) ::close(s.fd);
}

}  // namespace hapticd::daemon::telemetry
