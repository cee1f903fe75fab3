#pragma once
/// \file
/// The RT interface every scene implements. A scene maps the measured device
/// position y[n] (m or rad) to the force/torque commanded ON the device
/// (N or N m). See docs/scenes.md for each scene's law and sign conventions.
///
///  - reset(y): start at equilibrium at the measured position: zero output on
///    the next step(y) with the same y, virtual bodies at rest at y,
///    velocity estimator primed with y, delay line filled with zeros.
///  - step(y): output from the current state and y[n], then advance the state.
///    No allocation, no exceptions.
///  - channel_count / channel_names / channels(out): telemetry.

#include <array>
#include <concepts>
#include <cstddef>
#include <span>
#include <string_view>
#include <tuple>

namespace hapticd::world {

template <class S>
concept Scene = requires(S scene, const S& const_scene, double y, std::span<double> out) {
  { scene.reset(y) }
  noexcept->std::same_as<void>;
  { scene.step(y) }
  noexcept->std::same_as<double>;
  { const_scene.channels(out) }
  noexcept->std::same_as<void>;
  { S::channel_count } -> std::convertible_to<std::size_t>;
  requires std::same_as<std::remove_cvref_t<decltype(S::channel_names)>,
                        std::array<std::string_view, S::channel_count>>;
};

/// A scene's self-description (world/scene_description.hpp). Each scene
/// header declares its registry entry: the RT types it may be built as
/// (`alternatives`) and `describe()`, written in the scene's .cpp.
struct SceneDescription;

namespace detail {
/// Stand-in for a member a scene variant does not use. Distinct tags so that
/// several absent members can share storage under [[no_unique_address]].
template <int Tag>
struct Absent {};
}  // namespace detail

}  // namespace hapticd::world
