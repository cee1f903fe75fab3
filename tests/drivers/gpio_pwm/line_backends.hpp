#pragma once
// The GPIO chips the line tests run on: the umockdev testbed everywhere,
// and the kernel's gpio-sim where the kernel has it (configfs
// /sys/kernel/config/gpio-sim, root). The same tests run on both; checks
// that only the testbed can make (exact timestamps, the dropped-event count,
// the number of ioctls) are made only there.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace hapticd::drivers::gpio_pwm::testing_support {

class LineBackend {
 public:
  virtual ~LineBackend() = default;
  virtual std::string chip_path() const = 0;
  /// Drives an input line's physical level (gpio-sim: the line's pull).
  virtual void drive_input(unsigned offset, bool level, std::uint64_t timestamp_ns) = 0;
  /// An output line's physical level.
  virtual bool output_level(unsigned offset) = 0;
  /// The testbed sets event timestamps and counts drops and ioctls; gpio-sim
  /// timestamps are the kernel's own.
  virtual bool is_testbed() const = 0;
  virtual std::uint64_t dropped_events() const { return 0; }
  virtual std::uint64_t requests_served() const { return 0; }
};

/// "" when gpio-sim can be used here, otherwise why not.
std::string gpio_sim_unavailable_reason();

/// "umockdev" or "gpio-sim"; `line_names` one per line.
std::unique_ptr<LineBackend> make_line_backend(const std::string& kind,
                                               const std::vector<std::string>& line_names);

}  // namespace hapticd::drivers::gpio_pwm::testing_support
