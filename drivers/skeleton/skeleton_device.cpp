#include "drivers/skeleton/skeleton_device.hpp"

#include <chrono>
#include <cmath>
#include <limits>
#include <thread>

#include "world/text.hpp"

namespace hapticd::drivers::skeleton {

// ---- non-RT lifecycle -------------------------------------------------------

// configure(): the framework calls it once, closed -> configured. Open the
// bus, identify the device, check the period against the link's budget,
// arm the device's own watchdog if it has one. A failure throws DeviceError
// with the key to blame; the framework then calls close().
void SkeletonDevice::configure(const LoopContext& loop) {
  stop_ = loop.stop;
  check_period(config_, loop.period_s);
  link_.open(config_.socket);
  // Identify: one exchange with the power stage off. A real driver reads
  // its device's identity and limits here.
  const Reply first = control_exchange("configure", false, false);
  if (first.faulted)
    throw DeviceError("skeleton: the peer at " + config_.socket + " is in fault (code " +
                      world::text::format_hex(first.fault_code, 2) + "); clear it at the device");
  cause_.store(Cause::none, std::memory_order_release);
}

// enable(): configured -> enabled, and again after a clear. Power stage on
// with zero output first; confirm it, bounded.
void SkeletonDevice::enable() {
  command_.store(0, std::memory_order_relaxed);
  const Reply r = control_exchange("enable", true, false);
  if (!r.enabled) throw DeviceError("skeleton: the peer did not switch its power stage on");
  enabled_.store(true, std::memory_order_release);
}

// clear_fault(): on the control thread while the RT thread runs (the engine
// holds the output at zero). Reset the device, confirm, bounded; return what
// was cleared in words ("" if nothing); throw if the fault stays.
std::string SkeletonDevice::clear_fault() {
  const Cause cause = cause_.load(std::memory_order_acquire);
  if (cause == Cause::none) return "";
  const std::string what = health().fault_reason;
  const Reply r = control_exchange("clear fault", enabled_.load(std::memory_order_acquire), true);
  if (r.faulted)
    throw DeviceError("skeleton: the peer stays in fault after a reset (code " +
                      world::text::format_hex(r.fault_code, 2) + ")");
  streak_ = 0;
  cause_.store(Cause::none, std::memory_order_release);
  return what + ": reset";
}

// disable(): enabled -> configured; every exit path; noexcept. Output to
// zero, power stage off. The RT thread is no longer calling read()/write().
void SkeletonDevice::disable() noexcept {
  enabled_.store(false, std::memory_order_release);
  command_.store(0, std::memory_order_relaxed);
  try {
    (void)control_exchange("disable", false, false);
  } catch (const std::exception&) {
    // A dead link: the device's own watchdog (if it has one) takes over.
  }
}

// close(): -> closed; idempotent. Release the bus (disable() has run).
void SkeletonDevice::close() noexcept { link_.close(); }

// ---- RT -------------------------------------------------------------------

// read(): once a period, from configure() on. One exchange: the command the
// previous write() stored goes out, the position comes back. Bounded by
// the response timeout; a missing reply is an error, failure_streak of them
// in a row a fault; a device fault latches until clear_fault().
IoResult SkeletonDevice::read(Reading& out) noexcept {
  int expected = free_owner;
  if (!owner_.compare_exchange_strong(expected, rt_owner, std::memory_order_acquire)) {
    busy_.fetch_add(1, std::memory_order_relaxed);  // the control thread holds the link
    return IoResult::error;
  }
  Request request;
  request.sequence = ++sequence_;
  request.enable = enabled_.load(std::memory_order_relaxed);
  request.command =
      cause_.load(std::memory_order_relaxed) == Cause::none ? command_.load(std::memory_order_relaxed) : 0;
  Reply reply;
  const LinkOutcome outcome = link_.exchange(request, reply, config_.response_timeout_s);
  give_link();
  exchanges_.fetch_add(1, std::memory_order_relaxed);
  if (outcome == LinkOutcome::closed || outcome == LinkOutcome::io_error) return latch(Cause::link_lost, 0);
  if (outcome != LinkOutcome::ok) {
    (outcome == LinkOutcome::timeout ? timeouts_ : malformed_).fetch_add(1, std::memory_order_relaxed);
    return ++streak_ >= config_.failure_streak ? latch(Cause::no_reply, 0) : IoResult::error;
  }
  streak_ = 0;
  if (reply.faulted) return latch(Cause::peer_fault, reply.fault_code);
  if (cause_.load(std::memory_order_acquire) != Cause::none) return IoResult::fault;
  out.position = reply.position * config_.position_per_count();  // SI, converted once here
  return IoResult::ok;
}

// write(): once a period, only while enabled. Stores the command for the
// next read()'s exchange: counts, saturated to the wire's range.
IoResult SkeletonDevice::write(double force) noexcept {
  if (cause_.load(std::memory_order_acquire) != Cause::none) {
    command_.store(0, std::memory_order_relaxed);
    return IoResult::fault;
  }
  if (!std::isfinite(force)) {
    command_.store(0, std::memory_order_relaxed);
    return IoResult::error;
  }
  constexpr double most = std::numeric_limits<std::int32_t>::max();
  const double counts = std::clamp(std::round(force / config_.force_per_count), -most, most);
  command_.store(static_cast<std::int32_t>(counts), std::memory_order_relaxed);
  return IoResult::ok;
}

IoResult SkeletonDevice::latch(Cause cause, std::uint8_t code) noexcept {
  if (cause_.load(std::memory_order_relaxed) == Cause::none) {
    fault_code_.store(code, std::memory_order_relaxed);
    cause_.store(cause, std::memory_order_release);
  }
  command_.store(0, std::memory_order_relaxed);
  return IoResult::fault;
}

// ---- any non-RT thread ----------------------------------------------------

// model(): from configure() on. What the stability gate uses: from the
// config where the device cannot know it.
DeviceModel SkeletonDevice::model() const {
  DeviceModel m;
  m.motion = config_.motion;
  m.effective_mass = config_.mass;
  m.viscous_damping = config_.damping;
  m.position_resolution = config_.position_per_count();
  m.delay_periods = 1;  // read() sends the command write() stored a period earlier
  m.source = "config";
  m.description = "skeleton peer at " + config_.socket;
  return m;
}

// health(): the device's own fault latch and reason, and the driver's counters.
DeviceHealth SkeletonDevice::health() const {
  DeviceHealth h;
  const Cause cause = cause_.load(std::memory_order_acquire);
  h.faulted = cause != Cause::none;
  switch (cause) {
    case Cause::none:
      break;
    case Cause::peer_fault:
      h.fault_reason = "peer fault code " + world::text::format_hex(fault_code_.load(), 2);
      break;
    case Cause::no_reply:
      h.fault_reason = std::to_string(config_.failure_streak) + " exchanges in a row without a valid reply";
      break;
    case Cause::link_lost:
      h.fault_reason = "the link to the peer is lost: " + world::text::errno_text(link_.last_errno());
      break;
  }
  h.counters = {{"exchanges", exchanges_.load()},
                {"timeouts", timeouts_.load()},
                {"malformed_replies", malformed_.load()},
                {"stale_replies", link_.stale_replies()},
                {"link_busy", busy_.load()}};
  return h;
}

// ---- the control thread's use of the link ----------------------------------

void SkeletonDevice::take_link(const char* doing) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(1);
  for (int expected = free_owner;
       !owner_.compare_exchange_weak(expected, control_owner, std::memory_order_acquire);
       expected = free_owner) {
    throw_if_stopped(stop_, std::string("skeleton: ") + doing);
    if (std::chrono::steady_clock::now() > give_up)
      throw DeviceError(std::string("skeleton: ") + doing + ": the RT thread held the link for over 1 s");
    std::this_thread::sleep_for(std::chrono::microseconds(50));
  }
}

Reply SkeletonDevice::control_exchange(const char* doing, bool enable, bool reset) {
  take_link(doing);
  Request request;
  request.sequence = ++sequence_;
  request.enable = enable;
  request.reset = reset;
  Reply reply;
  // No period to fit here: ten response timeouts, at least 100 ms.
  const LinkOutcome outcome = link_.exchange(request, reply, std::max(10 * config_.response_timeout_s, 0.1));
  give_link();
  if (outcome != LinkOutcome::ok)
    throw DeviceError(
        std::string("skeleton: ") + doing + ": " + describe(outcome) + " from the peer at " + config_.socket,
        outcome == LinkOutcome::timeout ? "response_timeout" : "socket");
  return reply;
}

}  // namespace hapticd::drivers::skeleton
