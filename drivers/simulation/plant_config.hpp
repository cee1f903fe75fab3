#pragma once
/// \file
/// What the shared plant simulator simulates (DRIVERS.md "Simulated peers"):
/// a rigid mass or the two-mass cable plant of Diaz & Gil, Coulomb friction,
/// encoder quantization, actuator saturation and an extra output delay. The
/// loopback driver's parameters are exactly these (drivers/loopback/README.md).
/// SI units: for motion = rotary, "mass" is an inertia in kg m^2, forces are
/// torques in N m and positions are angles in rad.

#include <string_view>

#include "drivers/device.hpp"
#include "world/plant.hpp"

namespace hapticd::drivers::simulation {

enum class PlantKind { rigid, two_mass };

std::string_view to_string(PlantKind kind) noexcept;

/// Longest extra output delay the device accepts, in periods (fixed-size delay line).
inline constexpr int max_delay_periods = 64;

struct PlantConfig {
  Motion motion = Motion::rotary;
  PlantKind plant = PlantKind::rigid;
  /// Rigid plant: moving mass (kg) or inertia (kg m^2). Rotary default 0.01
  /// kg m^2 (a ~1 kg, 0.15 m radius wheel); linear default 0.1 kg (Hulin's PHANToM).
  double mass = 0.01;
  double damping = 0.0;  ///< rigid plant: viscous damping to ground, N s/m or N m s/rad
  double coulomb = 0.0;  ///< Coulomb friction level, N or N m (rigid: on the mass; two-mass: on the body)
  world::TwoMassPlant two_mass{};               ///< two-mass plant parameters (Diaz & Gil Table I defaults)
  world::Sensor sensor = world::Sensor::motor;  ///< two-mass: which position read() returns
  /// Encoder counts per revolution (rotary, default 4096*4) or per metre
  /// (linear, default 1/3.14e-6: the LHifAM encoder).
  double counts = 16384.0;
  /// Actuator saturation: largest |force| the device applies (rotary default
  /// 0.8 N m: Freudenberg's 800 N mm duty-cycle limit; linear default 10 N).
  double max_force = 0.8;
  int delay = 0;           ///< extra output delay, whole periods, 0..max_delay_periods
  double period_s = 1e-3;  ///< simulation period T, s

  /// The defaults for one kind of motion (mass, counts, max_force differ).
  static PlantConfig defaults(Motion motion);
  /// Position per encoder count: 2 pi / counts (rotary) or 1 / counts (linear).
  double resolution() const noexcept;
  /// Total moving mass (rigid: mass; two-mass: m_m + m_d).
  double total_mass() const noexcept;
  /// Total viscous damping to ground (rigid: damping; two-mass: b_m + b_d).
  double total_damping() const noexcept;
  /// Throws std::invalid_argument with one line naming the bad key (the
  /// loopback driver's parameter names).
  void validate() const;
};

}  // namespace hapticd::drivers::simulation
