#pragma once
/// \file
/// The skeleton driver's typed config ([device.skeleton]) and the period
/// budget. A real driver's <kind>_config holds the numbers that turn counts
/// and commands into SI (convert once, at the edge) and what the link needs.

#include <string>

#include "drivers/device_hooks.hpp"
#include "drivers/parameter.hpp"

namespace hapticd::drivers::skeleton {

struct SkeletonConfig {
  Motion motion = Motion::rotary;
  double mass = 0.0;                ///< kg m^2 or kg, for the stability gate
  double damping = 0.0;             ///< N m s/rad or N s/m
  std::string socket;               ///< the peer's SOCK_SEQPACKET path
  double counts_per_unit = 4096.0;  ///< encoder counts per revolution or metre
  double force_per_count = 1e-3;    ///< N m or N per command count
  double response_timeout_s = 0.5e-3;
  int failure_streak = 3;  ///< exchanges without a reply in a row that latch a fault

  /// rad or m per count.
  double position_per_count() const noexcept;
};

/// The typed parameters of [device.skeleton].
const std::vector<ParameterSpec>& skeleton_parameters();
/// The config from checked parameters; throws ParameterError naming the key.
SkeletonConfig skeleton_config_from(const DriverParameters& parameters);

/// The budget: one exchange a period must fit its response timeout inside
/// the period. Throws DeviceError("response_timeout") with the figures.
void check_period(const SkeletonConfig& config, double period_s);

}  // namespace hapticd::drivers::skeleton
