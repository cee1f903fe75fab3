#pragma once
/// \file
/// Every concrete scene type in one variant (made from the scene registry,
/// world/scene_registry.hpp), and RT-safe helpers over it.

#include <algorithm>
#include <cstddef>
#include <span>
#include <tuple>
#include <type_traits>
#include <utility>
#include <variant>

#include "world/scene_registry.hpp"

namespace hapticd::world {

namespace detail {
/// Variant<Vs...> with each of Ts... appended unless it is there already.
template <class Variant, class... Ts>
struct append_unique {
  using type = Variant;
};
template <class... Vs, class T, class... Ts>
struct append_unique<std::variant<Vs...>, T, Ts...> {
  using type = typename append_unique<
      std::conditional_t<(std::is_same_v<T, Vs> || ...), std::variant<Vs...>, std::variant<Vs..., T>>,
      Ts...>::type;
};
template <class First, class Alternatives>
struct variant_from;
template <class First, class... Ts>
struct variant_from<First, std::tuple<Ts...>> {
  using type = typename append_unique<std::variant<First>, Ts...>::type;
};
template <class First, class Registry>
struct scene_variant;
template <class First, class... Entries>
struct scene_variant<First, SceneList<Entries...>> {
  using type = typename variant_from<First, decltype(std::tuple_cat(
                                                std::declval<typename Entries::alternatives>()...))>::type;
};
}  // namespace detail

/// Every registered scene's RT types, each once, in registry order: what the
/// RT loop steps. FreeScene first, so that a default AnyScene outputs nothing.
using AnyScene = detail::scene_variant<FreeScene, SceneRegistry>::type;

namespace detail {
/// An entry's task-space types (Entry::task_alternatives), none if it has none.
template <class Entry>
struct task_alternatives_of {
  using type = std::tuple<>;
};
template <class Entry>
requires requires { typename Entry::task_alternatives; }
struct task_alternatives_of<Entry> {
  using type = typename Entry::task_alternatives;
};
template <class First, class Registry>
struct task_scene_variant;
template <class First, class... Entries>
struct task_scene_variant<First, SceneList<Entries...>> {
  using type = typename variant_from<
      First, decltype(std::tuple_cat(std::declval<typename task_alternatives_of<Entries>::type>()...))>::type;
};
}  // namespace detail

/// Every registered task-space scene type (world/task_scenes.hpp), for a
/// device with several axes: task position in, task force out.
/// TaskFreeScene first, so that a default AnyTaskScene outputs nothing.
using AnyTaskScene = detail::task_scene_variant<TaskFreeScene, SceneRegistry>::type;

inline void reset(AnyTaskScene& scene, const AxisVector& x) noexcept {
  std::visit([&x](auto& s) noexcept { s.reset(x); }, scene);
}

/// The task force at x, one entry per task axis.
inline void step(AnyTaskScene& scene, const AxisVector& x, AxisVector& force) noexcept {
  std::visit([&x, &force](auto& s) noexcept { s.step(x, force); }, scene);
}

inline std::size_t channel_count(const AnyTaskScene& scene) noexcept {
  return std::visit([](const auto& s) noexcept { return std::remove_cvref_t<decltype(s)>::channel_count; },
                    scene);
}

inline void channels(const AnyTaskScene& scene, std::span<double> out) noexcept {
  std::visit([out](const auto& s) noexcept { s.channels(out); }, scene);
}

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

namespace detail {
template <class Variant>
struct max_channels;
template <class... Scenes>
struct max_channels<std::variant<Scenes...>> {
  static constexpr std::size_t value = std::max({Scenes::channel_count...});
};
}  // namespace detail

/// Largest channel_count over all alternatives: size telemetry buffers with it.
inline constexpr std::size_t max_scene_channels = detail::max_channels<AnyScene>::value;

}  // namespace hapticd::world
