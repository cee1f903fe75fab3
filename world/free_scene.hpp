#pragma once
/// \file
/// `free`: zero output, no state (Freudenberg 3: the hand released, the device
/// moves freely).

#include <array>
#include <span>
#include <string_view>

#include "world/scene.hpp"
#include "world/task_scenes.hpp"

namespace hapticd::world {

class FreeScene {
 public:
  static constexpr std::size_t channel_count = 0;
  static constexpr std::array<std::string_view, channel_count> channel_names{};

  void reset(double /*measured_position*/) noexcept {}
  double step(double /*measured_position*/) noexcept { return 0.0; }
  void channels(std::span<double> /*out*/) const noexcept {}
};

static_assert(Scene<FreeScene>);

/// `free` in the scene registry (world/scene_registry.hpp); free_scene.cpp describes it.
struct FreeEntry {
  using alternatives = std::tuple<FreeScene>;
  /// On a device with several axes: zero force on every axis.
  using task_alternatives = std::tuple<TaskFreeScene>;
  static SceneDescription describe();
};

}  // namespace hapticd::world
