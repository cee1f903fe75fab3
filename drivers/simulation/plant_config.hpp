#pragma once
/// \file
/// What the shared plant simulator simulates (DRIVERS.md "Simulated peers"):
/// a rigid mass or the two-mass cable plant of Diaz & Gil, Coulomb friction,
/// encoder quantization, actuator saturation and an extra output delay. The
/// loopback driver's parameters are exactly these (drivers/loopback/README.md).
/// SI units: for motion = rotary, "mass" is an inertia in kg m^2, forces are
/// torques in N m and positions are angles in rad.

#include <string_view>

#include "drivers/device_hooks.hpp"
#include "drivers/parameter.hpp"
#include "world/plant.hpp"

namespace hapticd::drivers::simulation {

enum class PlantKind { rigid, two_mass };

std::string_view to_string(PlantKind kind) noexcept;

/// Longest extra output delay the device accepts, in periods (fixed-size delay line).
inline constexpr int max_delay_periods = 64;
/// Accepted simulation periods (s) and encoder resolutions (counts per
/// revolution or metre: 1 to 1e12, a picometre encoder). Masses, dampings,
/// stiffness and forces follow world::parameter_range.
inline constexpr double min_period_s = 1e-6;
inline constexpr double max_period_s = 1.0;
inline constexpr double max_counts = 1e12;

struct PlantConfig {
  Motion motion = Motion::rotary;
  PlantKind plant = PlantKind::rigid;
  /// Rigid plant: moving mass (kg) or inertia (kg m^2). Rotary default 0.01
  /// kg m^2 (a ~1 kg, 0.15 m radius wheel); linear default 0.1 kg (Hulin's PHANToM).
  double mass = 0.01;
  /// Rigid plant: viscous damping to ground, N m s/rad or N s/m. Rotary
  /// default 0.002 N m s/rad of bearing friction: an undamped wheel sampled
  /// with Freudenberg's virtual wheel (k = 1.0186 N m/rad, T = 1 ms) gains
  /// energy (Hulin eq. 7 after Gil et al. 2004: alpha < 2 beta, i.e.
  /// b > k T / 2 = 0.00051 N m s/rad), so the default scene would be
  /// refused. Linear default 0 (Hulin's device).
  double damping = 0.002;
  double coulomb = 0.0;  ///< Coulomb friction level, N or N m (rigid: on the mass; two-mass: on the body)
  world::TwoMassPlant two_mass{};               ///< two-mass plant parameters (Diaz & Gil Table I defaults)
  world::Sensor sensor = world::Sensor::motor;  ///< two-mass: which position read() returns
  /// Encoder counts per revolution (rotary, default 4096*4) or per metre
  /// (linear, default 1/3.14e-6: the LHifAM encoder).
  double counts = 16384.0;
  /// Actuator saturation: largest |force| the device applies. Rotary default
  /// 1.2 N m, above the daemon's default torque_limit of 1 N m (which covers
  /// Freudenberg's 800 N mm for a 45 degree move), so the software limit,
  /// not the actuator, is what clips; linear default 10 N.
  double max_force = 1.2;
  /// A constant force on the mass (N or N m), e.g. -m g on a vertical axis
  /// whose positive direction is up (issue 22 item 7); 0: a horizontal axis.
  double weight = 0.0;
  int delay = 0;           ///< extra output delay, whole periods, 0..max_delay_periods
  double period_s = 1e-3;  ///< simulation period T, s

  /// The defaults for one kind of motion (mass, damping, counts, max_force
  /// differ). The only source of the loopback's defaults: the daemon's
  /// built-in config and a config file that omits a key both get these.
  static PlantConfig defaults(Motion motion);
  /// Position per encoder count: 2 pi / counts (rotary) or 1 / counts (linear).
  double resolution() const noexcept;
  /// Total moving mass (rigid: mass; two-mass: m_m + m_d).
  double total_mass() const noexcept;
  /// Total viscous damping to ground (rigid: damping; two-mass: b_m + b_d).
  double total_damping() const noexcept;
  /// Throws ParameterError with one line naming the bad key (the loopback
  /// driver's parameter names).
  void validate() const;
};

}  // namespace hapticd::drivers::simulation
