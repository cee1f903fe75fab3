#pragma once
/// \file
/// The loopback driver's parameters ([device.loopback]) and its entry in the
/// driver registry. See README.md in this folder for what is simulated and
/// how. SI units throughout: for motion = rotary, "mass" is an inertia in
/// kg m^2, forces are torques in N m and positions are angles in rad.

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "drivers/driver_description.hpp"
#include "drivers/simulation/hand_script.hpp"
#include "drivers/simulation/pantograph_hand.hpp"
#include "drivers/simulation/plant_config.hpp"
#include "world/gravity.hpp"

namespace hapticd::drivers::loopback {

using simulation::max_delay_periods;
using simulation::PlantKind;
/// The loopback driver simulates exactly the shared plant simulator's plant.
using LoopbackConfig = simulation::PlantConfig;

/// Every key the loopback driver accepts, typed, with its default, range,
/// unit and help, in the order they are documented.
const std::vector<ParameterSpec>& loopback_parameters();

/// The plant configuration from checked parameters: "motion" selects the
/// defaults (mass, counts, max_force differ), the keys written override
/// them. Throws ParameterError naming the key.
LoopbackConfig loopback_config_from(const DriverParameters& parameters);
/// The hand script from the `hand` table (or its one-line text); throws
/// ParameterError naming the key ("hand.amplitude").
simulation::HandScript hand_script_from(const DriverParameters& parameters);

/// A Cartesian stage of several axes ([device.loopback] axes = N, issue
/// 22): one rigid, linear plant simulator per axis, each with its own mass,
/// damping and scripted hand; the other keys (counts, max_force, coulomb,
/// delay) are every axis'. One axis is exactly loopback_config_from and
/// hand_script_from.
struct LoopbackStage {
  std::vector<LoopbackConfig> axes;           ///< 1 to max_axes
  std::vector<simulation::HandScript> hands;  ///< one per axis
  /// linkage = "pantograph": the two axes are its motor joints (rigid,
  /// rotary: joint_inertia, joint_damping), the hand holds the handle.
  struct Pantograph {
    DeviceModel::Pantograph model;    ///< links and workspace
    std::array<double, 2> start{};    ///< the handle at start-up, m
    simulation::TaskHandScript hand;  ///< the `hand` key, on the handle
    /// link_masses: the linkage in a vertical plane (y up) weighs this;
    /// unset: weightless (a horizontal plane).
    std::optional<world::PantographMasses> weight;
  };
  std::optional<Pantograph> pantograph;
};

/// From checked parameters; throws ParameterError naming the key (axes,
/// axis_mass, axis_damping, hands, or a key a stage cannot take).
LoopbackStage loopback_stage_from(const DriverParameters& parameters);

/// "0.1,0.3" -> {0.1, 0.3}: exactly `count` comma-separated finite numbers
/// within [low, high]; throws ParameterError naming `key` and what is
/// accepted. Parsed once, at configuration.
std::vector<double> per_axis_numbers(std::string_view key, std::string_view text, int count, double low,
                                     double high, std::string_view unit);

/// From "key=value key=value ..." text (space separated), through the same
/// typed parameters; for tests and tools. Throws ParameterError.
LoopbackConfig parse_loopback_config(std::string_view text);

}  // namespace hapticd::drivers::loopback
