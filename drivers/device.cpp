#include "drivers/device.hpp"

#include <stdexcept>
#include <utility>

namespace hapticd::drivers {

std::string_view to_string(DeviceState state) noexcept {
  switch (state) {
    case DeviceState::closed:
      return "closed";
    case DeviceState::configured:
      return "configured";
    case DeviceState::enabled:
      return "enabled";
    case DeviceState::fault:
      return "fault";
  }
  return "closed";
}

Device::Device(std::string kind, std::unique_ptr<DeviceHooks> hooks)
    : kind_(std::move(kind)), hooks_(std::move(hooks)), axes_(hooks_ ? hooks_->axes() : 1) {
  if (!hooks_) throw std::invalid_argument(kind_ + ": a device needs its driver's hooks");
  if (axes_ < 1 || axes_ > max_axes)
    throw std::invalid_argument(kind_ + ": a device has 1 to " + std::to_string(max_axes) +
                                " axes; its driver says " + std::to_string(axes_));
}

Device::~Device() { close(); }

void Device::out_of_order(const char* step) const {
  const Lifecycle s = state_.load(std::memory_order_acquire);
  const char* now = s == Lifecycle::closed ? "closed" : s == Lifecycle::configured ? "configured" : "enabled";
  throw std::logic_error(kind_ + ": " + step + " while " + now);
}

template <class Step>
auto Device::guarded(const char* step, Step&& run) {
  const auto keep = [&](const std::string& message) {
    std::lock_guard lock(error_mutex_);
    last_error_ = message;
  };
  try {
    return run();
  } catch (const StopRequested&) {
    throw;
  } catch (const DeviceError& e) {
    keep(e.what());
    throw;
  } catch (const std::exception& e) {
    // A driver's own failure that is not a DeviceError (a system_error from
    // a socket, a runtime_error from a library): one line naming the step.
    DeviceError error(kind_ + ": " + step + ": " + e.what());
    keep(error.what());
    throw error;
  }
}

void Device::configure(const LoopContext& loop) {
  if (state_.load(std::memory_order_acquire) != Lifecycle::closed) out_of_order("configure()");
  try {
    guarded("configure", [&] { hooks_->configure(loop); });
  } catch (...) {
    hooks_->close();  // what the failed step opened
    throw;
  }
  latched_.store(false, std::memory_order_relaxed);
  state_.store(Lifecycle::configured, std::memory_order_release);
}

void Device::enable() {
  if (state_.load(std::memory_order_acquire) == Lifecycle::closed) out_of_order("enable()");
  try {
    guarded("enable", [&] { hooks_->enable(); });
  } catch (...) {
    hooks_->disable();  // output zero, power stage off, whatever the step reached
    state_.store(Lifecycle::configured, std::memory_order_release);
    throw;
  }
  state_.store(Lifecycle::enabled, std::memory_order_release);
}

std::string Device::clear_fault() {
  if (state_.load(std::memory_order_acquire) == Lifecycle::closed) out_of_order("clear_fault()");
  std::string cleared = guarded("clear fault", [&] { return hooks_->clear_fault(); });
  latched_.store(false, std::memory_order_release);
  return cleared;
}

void Device::disable() noexcept {
  Lifecycle expected = Lifecycle::enabled;
  if (state_.compare_exchange_strong(expected, Lifecycle::configured, std::memory_order_acq_rel))
    hooks_->disable();
}

void Device::close() noexcept {
  disable();
  if (state_.exchange(Lifecycle::closed, std::memory_order_acq_rel) != Lifecycle::closed) hooks_->close();
}

IoResult Device::counted_read(IoResult r) noexcept {
  if (r == IoResult::fault)
    count_fault();
  else
    read_errors_.fetch_add(1, std::memory_order_relaxed);
  return r;
}

IoResult Device::counted_write(IoResult r) noexcept {
  if (r == IoResult::fault)
    count_fault();
  else
    write_errors_.fetch_add(1, std::memory_order_relaxed);
  return r;
}

void Device::count_fault() noexcept {
  // Once per latch: the device reports its fault every period until cleared.
  if (!latched_.exchange(true, std::memory_order_acq_rel)) faults_.fetch_add(1, std::memory_order_relaxed);
}

DeviceModel Device::model() const {
  if (state_.load(std::memory_order_acquire) == Lifecycle::closed) out_of_order("model()");
  return hooks_->model();
}

std::string Device::identity() const {
  if (state_.load(std::memory_order_acquire) == Lifecycle::closed) out_of_order("identity()");
  std::string id = hooks_->identity();
  return id.empty() ? hooks_->model().description : id;
}

DeviceStatus Device::status() const {
  DeviceHealth health = hooks_->health();
  DeviceStatus s;
  const Lifecycle l = state_.load(std::memory_order_acquire);
  s.state = l == Lifecycle::closed                                       ? DeviceState::closed
            : latched_.load(std::memory_order_acquire) || health.faulted ? DeviceState::fault
            : l == Lifecycle::configured                                 ? DeviceState::configured
                                                                         : DeviceState::enabled;
  s.read_errors = read_errors_.load(std::memory_order_relaxed);
  s.write_errors = write_errors_.load(std::memory_order_relaxed);
  s.faults = faults_.load(std::memory_order_relaxed);
  s.fault_reason = std::move(health.fault_reason);
  if (!health.last_error.empty()) {
    s.last_error = std::move(health.last_error);
  } else {
    std::lock_guard lock(error_mutex_);
    s.last_error = last_error_;
  }
  s.counters = std::move(health.counters);
  return s;
}

}  // namespace hapticd::drivers
