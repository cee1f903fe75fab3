#pragma once
/// \file
/// A GPIO chip as the kernel's character device shows it through uAPI v1
/// (<linux/gpio.h>: GPIO_GET_CHIPINFO_IOCTL, GPIO_GET_LINEINFO_IOCTL,
/// GPIO_GET_LINEHANDLE_IOCTL, GPIOHANDLE_GET/SET_LINE_VALUES_IOCTL,
/// GPIO_GET_LINEEVENT_IOCTL and struct gpioevent_data), the uAPI libgpiod
/// 1.6 speaks. No system calls: the umockdev testbed turns ioctls into
/// these calls, and the board drives the input lines.
///
/// Kernel behaviour followed (drivers/gpio/gpiolib-cdev.c, v1 part):
/// - a handle request takes 1..64 lines, INPUT and OUTPUT exclude each
///   other, OPEN_DRAIN/OPEN_SOURCE need OUTPUT and exclude each other, bias
///   flags need a direction and at most one is set: otherwise EINVAL; an
///   offset past the last line is EINVAL; a line already requested is EBUSY;
/// - values are logical: ACTIVE_LOW inverts between the pin and the value;
/// - SET_LINE_VALUES on an input handle is EPERM;
/// - an event request is one input line (OUTPUT, OPEN_DRAIN, OPEN_SOURCE:
///   EINVAL); with both edges the event id is taken from the logical level
///   when the interrupt thread runs (RISING if 1), with one edge only that
///   logical edge is reported;
/// - a requested line's info has GPIOLINE_FLAG_KERNEL and the consumer.

#include <linux/gpio.h>

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace hapticd::drivers::gpio_pwm::sim {

using RequestId = std::uint32_t;

struct LineRequest {
  enum class Kind { handle, event } kind = Kind::handle;
  std::vector<unsigned> offsets;
  std::uint32_t handle_flags = 0;  ///< GPIOHANDLE_REQUEST_*
  std::uint32_t event_flags = 0;   ///< GPIOEVENT_REQUEST_*
  std::string consumer;
  bool output() const noexcept { return (handle_flags & GPIOHANDLE_REQUEST_OUTPUT) != 0; }
  bool active_low() const noexcept { return (handle_flags & GPIOHANDLE_REQUEST_ACTIVE_LOW) != 0; }
};

/// An edge the kernel queues for an event request.
struct LineEvent {
  RequestId request = 0;
  gpioevent_data data{};
};

class GpioChipModel {
 public:
  GpioChipModel(std::string name, std::string label, std::vector<std::string> line_names);

  unsigned num_lines() const noexcept { return static_cast<unsigned>(lines_.size()); }

  // The ioctls. Each returns 0 or the errno the kernel would return.
  int chip_info(gpiochip_info& out) const;
  int line_info(gpioline_info& inout) const;
  int request_handle(RequestId id, const gpiohandle_request& request);
  int request_event(RequestId id, const gpioevent_request& request);
  int get_values(RequestId id, gpiohandle_data& out) const;
  int set_values(RequestId id, const gpiohandle_data& values);
  /// The request's file was closed: its lines are free again.
  void release(RequestId id);
  /// From now on every value write fails with `error` and changes no line
  /// (a GPIO expander whose I2C bus died answers EIO); 0: works again.
  void fail_set_values(int error) noexcept { set_values_error_ = error; }

  /// The outside world drives an input line to a physical level. Returns
  /// the event the kernel would queue, if the line is watched for that edge.
  std::optional<LineEvent> drive_input(unsigned offset, bool physical_level, std::uint64_t timestamp_ns);

  bool physical_level(unsigned offset) const { return lines_.at(offset).physical; }
  /// Logical level of a line under its request (the physical level if free).
  bool logical_level(unsigned offset) const;
  bool requested(unsigned offset) const { return lines_.at(offset).owner.has_value(); }
  std::optional<unsigned> find_line(const std::string& name) const;
  const LineRequest* request(RequestId id) const;

 private:
  struct Line {
    std::string name;
    bool physical = false;
    bool is_output = false;
    std::optional<RequestId> owner;
  };
  int claim(RequestId id, LineRequest request);

  std::string name_, label_;
  std::vector<Line> lines_;
  std::map<RequestId, LineRequest> requests_;
  int set_values_error_ = 0;
};

}  // namespace hapticd::drivers::gpio_pwm::sim
