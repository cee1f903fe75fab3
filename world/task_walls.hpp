#pragma once
/// \file
/// Walls and shapes in task space (issue 22 item 3). Each is Hulin's
/// unilateral wall (world/wall_scene.hpp: F = -K pen - B v while
/// penetrating, never pulling, disarmed while loaded inside) on one scalar
/// coordinate s of the handle's task position x, pushing along that
/// coordinate's gradient:
///   plane-wall  s = n . x; the wall where s < offset (n points to free space)
///   sphere      s = |x - c|; the wall where s < R (outside: the device is
///               kept out of the ball) or s > R (inside: kept in it)
///   box         the device kept inside an axis-aligned box: one wall per
///               face, the force the sum of the penetrated faces'.
/// The vector force applied at n is the one computed at n - d (a delay line
/// of vectors, as a device delays what it was sent). Pure and RT-safe:
/// fixed-capacity vectors, no allocation. The types show what is used, as
/// the one-axis wall's: WallDamping::none has no velocity estimator,
/// WallDelay::none no delay line.

#include <array>
#include <cmath>
#include <cstddef>
#include <stdexcept>
#include <type_traits>

#include "world/kinematics.hpp"
#include "world/wall_scene.hpp"

namespace hapticd::world {

/// What every task-space wall takes: K and B along its coordinate, and d.
struct TaskWallLaw {
  double stiffness = 0.0;  ///< K, N/m, >= 0
  double damping = 0.0;    ///< B, N s/m, >= 0 (0 for WallDamping::none)
  int delay_samples = 0;   ///< d, 1..max_wall_delay_samples for WallDelay::samples, else 0
};

/// A delay line of task-space forces: push(F[n]) gives back F[n - d].
class TaskForceDelay {
 public:
  TaskForceDelay(int delay_samples, Eigen::Index dimensions);
  void reset() noexcept;
  void push(AxisVector& force) noexcept;  ///< in: F[n]; out: F[n - d]

 private:
  std::array<AxisVector, max_wall_delay_samples> buffer_;
  int delay_;
  int index_ = 0;
};

namespace detail {
/// The one-axis wall's law on one coordinate, without its own delay.
template <WallDamping Damping>
using CoordinateWall = WallScene<Damping, WallDelay::none>;

template <WallDamping Damping>
CoordinateWall<Damping> coordinate_wall(const TaskWallLaw& law, double surface, WallSide side,
                                        double period_s) {
  return CoordinateWall<Damping>({law.stiffness, law.damping, surface, side, 0}, period_s);
}

/// Unit vector of a task direction; throws for a zero or non-finite one.
AxisVector unit_normal(const AxisVector& direction);

/// The wall on one coordinate, and the delay of the vector force it makes:
/// what a plane and a sphere share.
template <WallDamping Damping, WallDelay Delay>
class CoordinateWallWithDelay {
  static constexpr bool delayed = Delay == WallDelay::samples;

 public:
  CoordinateWallWithDelay(const TaskWallLaw& law, double surface, WallSide side, Eigen::Index dimensions,
                          double period_s)
      : wall_(coordinate_wall<Damping>(law, surface, side, period_s)), delay_(make_delay(law, dimensions)) {}

  void reset(double s) noexcept {
    wall_.reset(s);
    if constexpr (delayed) delay_.reset();
  }
  /// The force along the coordinate at s (N), before the delay.
  double step(double s) noexcept { return wall_.step(s); }
  /// F[n] in, F[n - d] out.
  void delay(AxisVector& force) noexcept {
    if constexpr (delayed) delay_.push(force);
  }
  /// m, > 0 while penetrating.
  double penetration() const noexcept {
    std::array<double, CoordinateWall<Damping>::channel_count> p{};
    wall_.channels(p);
    return p[0];
  }

 private:
  static auto make_delay(const TaskWallLaw& law, Eigen::Index n) {
    if constexpr (delayed) {
      return TaskForceDelay(law.delay_samples, n);
    } else {
      return Absent<3>{};
    }
  }
  CoordinateWall<Damping> wall_;
  [[no_unique_address]] std::conditional_t<delayed, TaskForceDelay, Absent<3>> delay_;
};
}  // namespace detail

template <WallDamping Damping, WallDelay Delay>
class PlaneWall {
 public:
  /// The free side is n . x > offset. Throws std::invalid_argument.
  PlaneWall(const AxisVector& normal, double offset, const TaskWallLaw& law, double period_s)
      : normal_(detail::unit_normal(normal)), wall_(law, offset, WallSide::lower, normal.size(), period_s) {}

  void reset(const AxisVector& x) noexcept { wall_.reset(normal_.dot(x)); }
  void step(const AxisVector& x, AxisVector& force) noexcept {
    force = wall_.step(normal_.dot(x)) * normal_;
    wall_.delay(force);
  }
  double penetration() const noexcept { return wall_.penetration(); }
  const AxisVector& normal() const noexcept { return normal_; }

 private:
  AxisVector normal_;
  detail::CoordinateWallWithDelay<Damping, Delay> wall_;
};

template <WallDamping Damping, WallDelay Delay>
class SphereWall {
 public:
  /// inside: the device is held inside the ball; else kept out of it.
  SphereWall(const AxisVector& center, double radius, bool inside, const TaskWallLaw& law, double period_s)
      : center_(center),
        wall_(law, radius, inside ? WallSide::upper : WallSide::lower, center.size(), period_s) {
    if (!center.allFinite() || !(std::isfinite(radius) && radius > 0.0))
      throw std::invalid_argument("sphere: the center must be finite and the radius > 0 m");
  }

  void reset(const AxisVector& x) noexcept { wall_.reset((x - center_).norm()); }
  void step(const AxisVector& x, AxisVector& force) noexcept {
    const AxisVector from_center = x - center_;
    const double r = from_center.norm();
    const double radial = wall_.step(r);
    // At the very center the radial direction is undefined: no push there
    // (only an outside sphere reaches it, at full depth; the wall is
    // disarmed if the device starts inside, so a push there is never owed).
    if (r > 0.0) {
      force = (radial / r) * from_center;
    } else {
      force.setZero(x.size());
    }
    wall_.delay(force);
  }
  double penetration() const noexcept { return wall_.penetration(); }

 private:
  AxisVector center_;
  detail::CoordinateWallWithDelay<Damping, Delay> wall_;
};

template <WallDamping Damping, WallDelay Delay>
class BoxWall {
  static constexpr bool delayed = Delay == WallDelay::samples;
  using Face = detail::CoordinateWall<Damping>;

 public:
  /// The device is held inside [low, high] on every task axis (low < high).
  BoxWall(const AxisVector& low, const AxisVector& high, const TaskWallLaw& law, double period_s)
      : dimensions_(low.size()),
        faces_(make_faces(low, high, law, period_s)),
        delay_(make_delay(law, low.size())) {}

  void reset(const AxisVector& x) noexcept {
    for (Eigen::Index i = 0; i < dimensions_; ++i) {
      faces_[face(i, 0)].reset(x(i));
      faces_[face(i, 1)].reset(x(i));
    }
    if constexpr (delayed) delay_.reset();
  }
  void step(const AxisVector& x, AxisVector& force) noexcept {
    force.resize(dimensions_);
    for (Eigen::Index i = 0; i < dimensions_; ++i)
      force(i) = faces_[face(i, 0)].step(x(i)) + faces_[face(i, 1)].step(x(i));
    if constexpr (delayed) delay_.push(force);
  }
  /// The deepest penetration of any face, m.
  double penetration() const noexcept {
    double deepest = 0.0;
    for (Eigen::Index i = 0; i < 2 * dimensions_; ++i) {
      std::array<double, Face::channel_count> p{};
      faces_[static_cast<std::size_t>(i)].channels(p);
      deepest = std::max(deepest, p[0]);
    }
    return deepest;
  }

 private:
  static constexpr std::size_t box_faces = 2 * static_cast<std::size_t>(max_axes);  ///< low and high per axis
  static std::size_t face(Eigen::Index axis, int high) noexcept {
    return static_cast<std::size_t>(2 * axis + high);
  }
  static std::array<Face, box_faces> make_faces(const AxisVector& low, const AxisVector& high,
                                                const TaskWallLaw& law, double period_s) {
    if (low.size() != high.size() || low.size() < 1 || !low.allFinite() || !high.allFinite() ||
        !(low.array() < high.array()).all())
      throw std::invalid_argument(
          "box: low and high must be finite, of the same size, with low < high on every axis");
    // Unused faces (axes beyond the box's dimensions) are built and never stepped.
    auto at = [&](std::size_t f) {
      const auto axis = static_cast<Eigen::Index>(f / 2);
      if (axis >= low.size()) return detail::coordinate_wall<Damping>(law, 0.0, WallSide::lower, period_s);
      return f % 2 == 0 ? detail::coordinate_wall<Damping>(law, low(axis), WallSide::lower, period_s)
                        : detail::coordinate_wall<Damping>(law, high(axis), WallSide::upper, period_s);
    };
    return [&]<std::size_t... f>(std::index_sequence<f...>) { return std::array<Face, box_faces>{at(f)...}; }
    (std::make_index_sequence<box_faces>{});
  }
  static auto make_delay(const TaskWallLaw& law, Eigen::Index n) {
    if constexpr (delayed) {
      return TaskForceDelay(law.delay_samples, n);
    } else {
      return detail::Absent<3>{};
    }
  }
  Eigen::Index dimensions_;
  std::array<Face, box_faces> faces_;
  [[no_unique_address]] std::conditional_t<delayed, TaskForceDelay, detail::Absent<3>> delay_;
};

}  // namespace hapticd::world
