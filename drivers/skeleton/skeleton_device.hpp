#pragma once
/// \file
/// The skeleton driver's hooks: a blank driver to copy (docs/drivers.md,
/// "Writing a driver"), as CANopenNode's CO_driver_blank.c and LinuxCNC's
/// hal_skeleton.c. Every hook the framework calls is here, each saying what
/// the framework guarantees before it runs and what the hook must leave
/// behind. The framework's Device (drivers/device.hpp) holds the lifecycle:
/// no hook checks the order, counts errors or translates exceptions.
///
/// Threads, as in every driver: read() and write() on the RT thread, once a
/// period, without allocation, lock, text or any syscall but the link's
/// I/O; clear_fault() on the control thread WHILE the RT thread runs. They
/// share the link through an owner word (compare-exchange): the RT thread
/// takes it without waiting (busy: this period is an error), the control
/// thread waits for it, bounded.

#include <atomic>
#include <cstdint>
#include <string>

#include "drivers/device_hooks.hpp"
#include "drivers/skeleton/skeleton_config.hpp"
#include "drivers/skeleton/skeleton_link.hpp"

namespace hapticd::drivers::skeleton {

class SkeletonDevice final : public DeviceHooks {
 public:
  explicit SkeletonDevice(SkeletonConfig config) : config_(std::move(config)) {}

  void configure(const LoopContext& loop) override;
  void enable() override;
  std::string clear_fault() override;
  void disable() noexcept override;
  void close() noexcept override;
  IoResult read(Reading& out) noexcept override;
  IoResult write(double force) noexcept override;
  DeviceModel model() const override;
  DeviceHealth health() const override;

  const SkeletonConfig& config() const noexcept { return config_; }

 private:
  /// Why the driver latched a fault (RT-safe: a code, no text).
  enum class Cause : std::uint8_t { none, peer_fault, no_reply, link_lost };

  IoResult latch(Cause cause, std::uint8_t code) noexcept;
  /// A control-thread exchange (link taken, bounded wait); throws DeviceError.
  Reply control_exchange(const char* doing, bool enable, bool reset);
  void take_link(const char* doing);
  void give_link() noexcept { owner_.store(free_owner, std::memory_order_release); }

  enum Owner : int { free_owner = 0, rt_owner = 1, control_owner = 2 };

  const SkeletonConfig config_;
  StopToken stop_;
  SkeletonLink link_;
  std::uint16_t sequence_ = 0;  ///< the link's owner only
  int streak_ = 0;              ///< exchanges without a reply in a row (RT)

  std::atomic<int> owner_{free_owner};
  std::atomic<bool> enabled_{false};
  std::atomic<std::int32_t> command_{0};  ///< write() -> the next read()'s request
  std::atomic<Cause> cause_{Cause::none};
  std::atomic<std::uint8_t> fault_code_{0};
  std::atomic<std::uint64_t> exchanges_{0}, timeouts_{0}, malformed_{0}, busy_{0};
};

}  // namespace hapticd::drivers::skeleton
