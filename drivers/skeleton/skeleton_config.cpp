#include "drivers/skeleton/skeleton_config.hpp"

#include <numbers>

#include "world/units.hpp"

namespace hapticd::drivers::skeleton {

namespace {

using P = ParameterSpec;

std::vector<ParameterSpec> make_parameters() {
  const SkeletonConfig d;
  // The keys every device takes come first, declared once (drivers/parameter.hpp).
  return {
      motion_parameter(),
      mass_parameter(),
      damping_parameter(),
      P::text("socket", "the peer's SOCK_SEQPACKET socket path"),
      P::number("counts_per_unit", "1/rev | 1/m", "encoder counts per revolution (rotary) or metre (linear)")
          .defaults_to(d.counts_per_unit)
          .above(0.0)
          .at_most(1e12),
      P::number("force_per_count", "N m | N", "force or torque of one command count")
          .defaults_to(d.force_per_count)
          .above(0.0)
          .at_most(1e3),
      P::duration("response_timeout", "the longest wait for the peer's reply, each period")
          .defaults_to(d.response_timeout_s)
          .at_least(10e-6)
          .at_most(1.0),
      P::integer("failure_streak", "", "exchanges without a valid reply in a row that latch a fault")
          .defaults_to(static_cast<double>(d.failure_streak))
          .at_least(1)
          .at_most(1000),
  };
}

}  // namespace

double SkeletonConfig::position_per_count() const noexcept {
  return (motion == Motion::rotary ? 2.0 * std::numbers::pi : 1.0) / counts_per_unit;
}

const std::vector<ParameterSpec>& skeleton_parameters() {
  static const std::vector<ParameterSpec> parameters = make_parameters();
  return parameters;
}

SkeletonConfig skeleton_config_from(const DriverParameters& p) {
  SkeletonConfig c;
  c.motion = p.text("motion") == "linear" ? Motion::linear : Motion::rotary;
  c.mass = p.number("mass");
  c.damping = p.number("damping");
  c.socket = p.text("socket");
  if (c.socket.empty())
    throw ParameterError("socket", "device.skeleton.socket: the peer's socket path is empty");
  c.counts_per_unit = p.number("counts_per_unit");
  c.force_per_count = p.number("force_per_count");
  c.response_timeout_s = p.duration_s("response_timeout");
  c.failure_streak = static_cast<int>(p.integer("failure_streak"));
  return c;
}

void check_period(const SkeletonConfig& config, double period_s) {
  if (config.response_timeout_s <= period_s) return;
  throw DeviceError("skeleton: the response timeout " +
                        world::units::format_duration(config.response_timeout_s) +
                        " does not fit in the period " + world::units::format_duration(period_s) +
                        ": use a period of at least the timeout, or a shorter timeout",
                    "response_timeout");
}

}  // namespace hapticd::drivers::skeleton
