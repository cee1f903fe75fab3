#pragma once
/// \file
/// Scenes in task space, for a device with several axes (issue 22): the
/// handle's task position x in (m, one coordinate per task axis), the task
/// force F out (N), which the engine maps to the joints by tau = J^T F. The
/// shapes are world/task_walls.hpp's (Hulin's unilateral wall on one scalar
/// coordinate of x, pushing along its gradient); here they are registry
/// entries: parameters, factory, and what the stability gate judges
/// (TaskWallJudgement: the one-axis wall rule along given directions).
///
///   plane-wall  the free side n . x > offset
///   sphere      the device kept outside (or inside) a ball
///   box         the device kept inside an axis-aligned box
///
/// A task scene carries only what it uses: the WallDamping / WallDelay
/// variants of its shape.

#include <array>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <tuple>
#include <vector>

#include "world/kinematics.hpp"
#include "world/scene_description.hpp"
#include "world/task_walls.hpp"

namespace hapticd::world {

/// `free` on a device with several axes: zero force on every axis.
class TaskFreeScene {
 public:
  static constexpr std::size_t channel_count = 0;
  static constexpr std::array<std::string_view, channel_count> channel_names{};
  void reset(const AxisVector& /*x*/) noexcept {}
  void step(const AxisVector& x, AxisVector& force) noexcept { force.setZero(x.size()); }
  void channels(std::span<double> /*out*/) const noexcept {}
};

/// A task-space wall shape with its telemetry: the penetration of its
/// coordinate (the deepest face's for a box).
template <class Shape>
class TaskWallScene {
 public:
  static constexpr std::size_t channel_count = 1;
  static constexpr std::array<std::string_view, channel_count> channel_names{"penetration"};
  explicit TaskWallScene(Shape shape) : shape_(std::move(shape)) {}
  void reset(const AxisVector& x) noexcept { shape_.reset(x); }
  void step(const AxisVector& x, AxisVector& force) noexcept { shape_.step(x, force); }
  void channels(std::span<double> out) const noexcept {
    if (out.size() >= channel_count) out[0] = shape_.penetration();
  }
  const Shape& shape() const noexcept { return shape_; }

 private:
  Shape shape_;
};

/// Every WallDamping x WallDelay variant of a shape, as task scenes.
template <template <WallDamping, WallDelay> class Shape>
using TaskWallVariants =
    std::tuple<TaskWallScene<Shape<WallDamping::none, WallDelay::none>>,
               TaskWallScene<Shape<WallDamping::none, WallDelay::samples>>,
               TaskWallScene<Shape<WallDamping::backward_difference, WallDelay::none>>,
               TaskWallScene<Shape<WallDamping::backward_difference, WallDelay::samples>>>;

/// What the stability gate judges for a task-space wall: Hulin's one-axis
/// wall with the scene's law along each direction, on the mass the device
/// has there (analysis/task_space.hpp).
struct TaskWallJudgement {
  TaskWallLaw law;
  /// Unit task directions, each with its words ("the normal (0.707, 0.707)",
  /// "axis 2"); empty: the worst direction of the device (the lightest m_n),
  /// as for a sphere, whose radius may point anywhere.
  std::vector<AxisVector> directions;
  std::vector<std::string> labels;
  /// Box faces: direction i is task axis i (the gate names the axis).
  bool along_axes = false;
};

/// The registry entries (world/scene_registry.hpp); task_scenes.cpp describes them.
struct PlaneWallEntry {
  using alternatives = std::tuple<>;
  using task_alternatives = TaskWallVariants<PlaneWall>;
  static SceneDescription describe();
};
struct SphereEntry {
  using alternatives = std::tuple<>;
  using task_alternatives = TaskWallVariants<SphereWall>;
  static SceneDescription describe();
};
struct BoxEntry {
  using alternatives = std::tuple<>;
  using task_alternatives = TaskWallVariants<BoxWall>;
  static SceneDescription describe();
};

/// "1,1" -> (1, 1): exactly `axes` comma-separated finite numbers, each
/// within +-`bound` when one is given (a position: parameter_range's, m);
/// "" gives `empty`. Throws std::invalid_argument naming `name` and what is
/// accepted.
AxisVector parse_axis_vector(std::string_view name, std::string_view text, int axes, const AxisVector& empty,
                             std::optional<double> bound = std::nullopt);

}  // namespace hapticd::world
