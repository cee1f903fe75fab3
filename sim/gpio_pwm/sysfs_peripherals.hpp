#pragma once
/// \file
/// The simulated board's PWM chip and counter as sysfs attribute files
/// under a root directory (the umockdev testbed's, so that the driver's
/// /sys/class/pwm/... and /sys/bus/counter/... paths land here; or any
/// directory, for tests that give the driver the real paths).
///
/// The files are plain files, which take any write; the kernel's store()
/// refuses some. So the chip installs a SysfsStoreHook on its directory:
/// every pwrite() the driver makes to an attribute is applied, at once,
/// through PwmChannelModel (the kernel's rules), and either stored (the file
/// then reads as the kernel would print it) or refused with the kernel's
/// errno (EINVAL: duty above period, period 0; EBUSY: polarity while
/// enabled), which the driver's pwrite() returns, as on a real chip. A
/// write of N to "export" creates pwmN/ before the pwrite() returns, as the
/// kernel does.

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "sim/gpio_pwm/pwm_channel_model.hpp"
#include "sim/gpio_pwm/sysfs_store_hook.hpp"

namespace hapticd::drivers::gpio_pwm::sim {

struct RefusedWrite {
  unsigned channel = 0;
  std::string attribute;
  std::string text;
  int error = 0;
};

class SimulatedPwmChip {
 public:
  /// Creates <root><chip_path> (e.g. /sys/class/pwm/pwmchip0) with npwm,
  /// export and unexport, and installs the store hook on it. `exported`
  /// channels get their pwmN/ at once, with `initial` state; the others
  /// when "N" is written to export.
  SimulatedPwmChip(const std::string& root, const std::string& chip_path, unsigned npwm,
                   const std::vector<unsigned>& exported = {}, PwmChannelState initial = {});
  SimulatedPwmChip(const SimulatedPwmChip&) = delete;
  SimulatedPwmChip& operator=(const SimulatedPwmChip&) = delete;

  /// The kernel's view of a channel; throws std::out_of_range if not exported.
  PwmChannelState state(unsigned channel) const;
  bool exported(unsigned channel) const;
  /// Writes the kernel would have refused (and the driver was told so).
  std::vector<RefusedWrite> refused() const;
  /// Attribute writes stored or refused so far.
  std::uint64_t writes_seen() const;
  /// From now on every store fails with `error` (a chip whose bus died:
  /// EIO) and changes nothing; 0: works again.
  void fail_stores(int error);
  std::string chip_dir() const { return chip_dir_; }

 private:
  int store(const char* path, std::string_view text);
  void create_channel(unsigned channel);
  std::string channel_dir(unsigned channel) const { return chip_dir_ + "/pwm" + std::to_string(channel); }

  std::string chip_dir_;
  unsigned npwm_;
  PwmChannelState initial_;
  mutable std::mutex mutex_;
  std::map<unsigned, PwmChannelModel> channels_;
  std::vector<RefusedWrite> refused_;
  std::uint64_t writes_seen_ = 0;
  int store_error_ = 0;
  SysfsStoreHook hook_;  // last: installed once the rest exists
};

class SimulatedCounter {
 public:
  /// Creates <root><counter_path>/count<index>/{count,ceiling,function}.
  SimulatedCounter(const std::string& root, const std::string& counter_path, unsigned index,
                   std::uint64_t ceiling, const std::string& function = "quadrature x4");
  /// The raw count for a position in counts (wrapped into 0..ceiling).
  void set_position(std::int64_t counts);
  std::uint64_t raw() const noexcept { return raw_; }
  std::string count_path() const;  ///< the real file

 private:
  std::string count_file_;
  std::uint64_t ceiling_;
  std::uint64_t raw_ = 0;
};

}  // namespace hapticd::drivers::gpio_pwm::sim
