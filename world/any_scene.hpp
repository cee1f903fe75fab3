#pragma once
/// \file
/// Every concrete scene type in one variant, and RT-safe helpers over it.

#include <cstddef>
#include <span>
#include <variant>

#include "world/chirp_scene.hpp"
#include "world/free_scene.hpp"
#include "world/relay_scene.hpp"
#include "world/spring_scene.hpp"
#include "world/wall_scene.hpp"

namespace hapticd::world {

using AnyScene = std::variant<FreeScene,                                      //
                              SpringScene<SpringDamping::none>,               //
                              SpringScene<SpringDamping::absolute>,           //
                              SpringScene<SpringDamping::relative>,           //
                              WallScene<WallDamping::none, WallDelay::none>,  //
                              WallScene<WallDamping::none, WallDelay::samples>,
                              WallScene<WallDamping::backward_difference, WallDelay::none>,
                              WallScene<WallDamping::backward_difference, WallDelay::samples>,
                              RelayScene<RelayHysteresis::none>,  //
                              RelayScene<RelayHysteresis::band>,  //
                              RelayScene<RelayHysteresis::none, RelayDelay::samples>,
                              RelayScene<RelayHysteresis::band, RelayDelay::samples>,  //
                              ChirpScene>;

inline void reset(AnyScene& scene, double measured_position) noexcept {
  std::visit([measured_position](auto& s) noexcept { s.reset(measured_position); }, scene);
}

inline double step(AnyScene& scene, double measured_position) noexcept {
  return std::visit([measured_position](auto& s) noexcept { return s.step(measured_position); }, scene);
}

inline std::size_t channel_count(const AnyScene& scene) noexcept {
  return std::visit([](const auto& s) noexcept { return std::remove_cvref_t<decltype(s)>::channel_count; },
                    scene);
}

/// Writes channel_count(scene) values (nothing if out is shorter).
inline void channels(const AnyScene& scene, std::span<double> out) noexcept {
  std::visit([out](const auto& s) noexcept { s.channels(out); }, scene);
}

/// Largest channel_count over all alternatives: size telemetry buffers with it.
inline constexpr std::size_t max_scene_channels = 3;

}  // namespace hapticd::world
