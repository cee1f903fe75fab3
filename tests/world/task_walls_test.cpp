// Walls and shapes in task space (world/task_walls.hpp): the force is along
// the normal (or the radius) with magnitude K times the penetration along it,
// zero outside; the delay delays the vector; a box's corner sums its faces;
// a wall loaded with the device inside stays disarmed; nothing allocates.

#include "world/task_walls.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "tests/support/alloc_counter.hpp"

namespace task_walls_test {

namespace {

using namespace hapticd::world;

AxisVector vec(double a, double b) {
  AxisVector v(2);
  v << a, b;
  return v;
}

constexpr double period = 1e-3;

TEST(TaskWalls, APlaneWallPushesAlongItsNormalWithKTimesThePenetrationAlongIt) {
  const TaskWallLaw law{2000.0, 0.0, 0};
  PlaneWall<WallDamping::none, WallDelay::none> wall(vec(1, 1), 0.0, law, period);
  const AxisVector n = vec(1, 1) / std::sqrt(2.0);
  wall.reset(vec(0.01, 0.0));  // outside: n . x > 0
  AxisVector f;
  // The hand pushes along -x, through the plane.
  for (int mm = 10; mm >= -10; --mm) {
    const double x = 1e-3 * mm;
    wall.step(vec(x, 0.0), f);
    const double depth = std::max(0.0, -n.dot(vec(x, 0.0)));
    EXPECT_NEAR((f - 2000.0 * depth * n).norm(), 0.0, 1e-12) << "x = " << x;
    if (depth > 0) {
      EXPECT_NEAR(std::abs(f.normalized().dot(n)), 1.0, 1e-15);
    }
  }
  EXPECT_NEAR(wall.penetration(), 0.01 / std::sqrt(2.0), 1e-12);
}

TEST(TaskWalls, DampingActsOnTheVelocityAlongTheNormalAndNeverPulls) {
  const TaskWallLaw law{1000.0, 10.0, 0};
  PlaneWall<WallDamping::backward_difference, WallDelay::none> wall(vec(0, 1), 0.0, law, period);
  wall.reset(vec(0.0, 0.0));
  AxisVector f;
  wall.step(vec(0.5, -0.001), f);  // 1 mm in along -y in one period (1 m/s), any motion along x
  EXPECT_NEAR(f(1), 1000.0 * 0.001 + 10.0 * 1.0, 1e-9);
  EXPECT_EQ(f(0), 0.0);
  wall.step(vec(0.5, -0.0001), f);  // withdrawing fast: the PD would pull; the wall does not
  EXPECT_GE(f(1), 0.0);
}

TEST(TaskWalls, TheDelayDelaysTheWholeVector) {
  const TaskWallLaw law{2000.0, 0.0, 3};
  PlaneWall<WallDamping::none, WallDelay::samples> late(vec(1, 2), 0.0, law, period);
  PlaneWall<WallDamping::none, WallDelay::none> now(vec(1, 2), 0.0, {2000.0, 0.0, 0}, period);
  late.reset(vec(0.01, 0.01));
  now.reset(vec(0.01, 0.01));
  std::vector<AxisVector> sent;
  AxisVector f, g;
  for (int k = 0; k < 20; ++k) {
    const AxisVector x = vec(0.01 - 0.002 * k, 0.003);
    late.step(x, f);
    now.step(x, g);
    sent.push_back(g);
    if (k < 3) {
      EXPECT_EQ(f, vec(0, 0));
    } else {
      EXPECT_EQ(f, sent[static_cast<std::size_t>(k - 3)]) << k;
    }
  }
}

TEST(TaskWalls, AWallLoadedWithTheDeviceInsideWaitsUntilItHasBeenOutside) {
  PlaneWall<WallDamping::none, WallDelay::none> wall(vec(1, 0), 0.0, {2000.0, 0.0, 0}, period);
  wall.reset(vec(-0.01, 0.0));  // 1 cm deep at load
  AxisVector f;
  wall.step(vec(-0.01, 0.0), f);
  EXPECT_EQ(f, vec(0, 0)) << "no step of K x depth at load";
  wall.step(vec(0.001, 0.0), f);
  wall.step(vec(-0.002, 0.0), f);
  EXPECT_NEAR(f(0), 4.0, 1e-12) << "armed once it was outside";
}

TEST(TaskWalls, ASpherePushesAlongTheRadiusOutOfItOrBackIntoIt) {
  const TaskWallLaw law{500.0, 0.0, 0};
  SphereWall<WallDamping::none, WallDelay::none> ball(vec(0.1, 0.1), 0.02, false, law, period);
  ball.reset(vec(0.2, 0.1));
  AxisVector f;
  ball.step(vec(0.1 + 0.012, 0.1 + 0.009), f);  // r = 15 mm: 5 mm deep
  EXPECT_NEAR(f.norm(), 500.0 * 0.005, 1e-12);
  EXPECT_NEAR(f.normalized().dot(vec(0.8, 0.6)), 1.0, 1e-12) << "outward, along the radius";
  ball.step(vec(0.2, 0.1), f);
  EXPECT_EQ(f, vec(0, 0));

  SphereWall<WallDamping::none, WallDelay::none> room(vec(0, 0), 0.05, true, law, period);
  room.reset(vec(0, 0));
  room.step(vec(0.0, 0.06), f);  // 1 cm beyond the inside of the sphere
  EXPECT_NEAR(f(1), -500.0 * 0.01, 1e-12);
  EXPECT_NEAR(f(0), 0.0, 1e-15);
}

TEST(TaskWalls, ABoxCornerSumsThePenetratedFaces) {
  const TaskWallLaw law{1000.0, 0.0, 0};
  BoxWall<WallDamping::none, WallDelay::none> box(vec(-0.05, -0.05), vec(0.05, 0.05), law, period);
  box.reset(vec(0, 0));
  AxisVector f;
  box.step(vec(0.0, 0.0), f);
  EXPECT_EQ(f, vec(0, 0));
  box.step(vec(0.052, -0.053), f);  // past the +x face by 2 mm and the -y face by 3 mm
  EXPECT_NEAR(f(0), -2.0, 1e-12);
  EXPECT_NEAR(f(1), 3.0, 1e-12);
  EXPECT_NEAR(box.penetration(), 0.003, 1e-12);
  EXPECT_THROW((BoxWall<WallDamping::none, WallDelay::none>(vec(0, 0), vec(0, 1), law, period)),
               std::invalid_argument);
}

TEST(TaskWalls, BadNormalsAreRefused) {
  EXPECT_THROW((PlaneWall<WallDamping::none, WallDelay::none>(vec(0, 0), 0.0, {}, period)),
               std::invalid_argument);
  EXPECT_THROW((SphereWall<WallDamping::none, WallDelay::none>(vec(0, 0), -1.0, true, {}, period)),
               std::invalid_argument);
}

TEST(TaskWalls, TheRtStepAllocatesNothing) {
  ASSERT_TRUE(hapticd::testing::allocation_counting_active());
  const TaskWallLaw law{1000.0, 5.0, 2};
  PlaneWall<WallDamping::backward_difference, WallDelay::samples> plane(vec(1, 1), 0.0, law, period);
  SphereWall<WallDamping::backward_difference, WallDelay::samples> ball(vec(0, 0), 0.02, false, law, period);
  BoxWall<WallDamping::backward_difference, WallDelay::samples> box(vec(-0.1, -0.1), vec(0.1, 0.1), law,
                                                                    period);
  plane.reset(vec(0.05, 0));
  ball.reset(vec(0.05, 0));
  box.reset(vec(0.05, 0));
  AxisVector f;
  double total = 0.0;
  std::size_t allocations = 0;
  {
    hapticd::testing::AllocationGuard guard;
    for (int k = 0; k < 200; ++k) {
      const AxisVector x = vec(0.05 - 0.0007 * k, 0.001 * std::sin(0.1 * k));
      plane.step(x, f);
      total += f.norm();
      ball.step(x, f);
      total += f.norm();
      box.step(x, f);
      total += f.norm();
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0U);
  EXPECT_GT(total, 0.0);
}

}  // namespace

}  // namespace task_walls_test
