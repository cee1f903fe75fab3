// The loopback's pantograph (issue 22): two rigid rotary joints on the
// shared plant simulator, the linkage's kinematics between them and the
// handle, and the hand on the handle in task space (a force through J^T,
// a spring, an ideal hold) or on a joint. The joints' motion is checked
// against the equations it must follow: I q'' = J^T F for a hand force on
// free joints, q = IK(r(t)) for a held handle, I q'' = -dV/dq for the
// links' weight in a vertical plane.

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>
#include <string>

#include <nlohmann/json.hpp>

#include "drivers/loopback/loopback_config.hpp"
#include "drivers/loopback/loopback_device.hpp"
#include "rpc/jsonrpc.hpp"
#include "tests/support/alloc_counter.hpp"
#include "world/gravity.hpp"
#include "world/kinematics.hpp"

namespace loopback_pantograph_test {

namespace {

using namespace hapticd::drivers;
using hapticd::drivers::loopback::LoopbackDevice;
namespace world = hapticd::world;

DriverParameters keys(std::map<std::string, ParameterValue, std::less<>> given) {
  given.emplace("linkage", "pantograph");
  return DriverParameters("loopback", loopback::loopback_parameters(), given);
}

world::AxisVector handle(const world::PantographKinematics& k, const std::array<Reading, 2>& r) {
  world::AxisVector q(2);
  q << r[0].position, r[1].position;
  world::TaskState s;
  k.solve(q, s);
  EXPECT_EQ(s.status, world::KinematicsStatus::ok);
  return s.position;
}

std::string refusal(std::map<std::string, ParameterValue, std::less<>> given) {
  try {
    loopback::loopback_stage_from(keys(std::move(given)));
  } catch (const ParameterError& e) {
    return e.key() + ": " + e.what();
  }
  return "accepted";
}

}  // namespace

TEST(LoopbackPantograph, TwoRotaryJointsAtTheStartWithTheLinkageInTheModel) {
  const auto stage = loopback::loopback_stage_from(
      keys({{"joint_inertia", "0.0004,0.0006"}, {"joint_damping", "0.001,0"}, {"start", "0.01,0.1"}}));
  ASSERT_EQ(stage.axes.size(), 2U);
  ASSERT_TRUE(stage.pantograph.has_value());
  LoopbackDevice device(stage);
  device.configure({1e-3});
  const DeviceModel m = device.model();
  EXPECT_EQ(m.motion, Motion::rotary);
  ASSERT_EQ(m.axes.size(), 2U);
  EXPECT_EQ(m.axes[0].mass, 0.0004);
  EXPECT_EQ(m.axes[1].mass, 0.0006);
  EXPECT_EQ(m.axes[0].damping, 0.001);
  ASSERT_TRUE(m.pantograph.has_value());
  EXPECT_EQ(m.pantograph->y_max, 0.12);
  // The encoders read the joint angles of the start, to one count.
  std::array<Reading, 2> r{};
  ASSERT_EQ(device.read_axes(r), IoResult::ok);
  const world::PantographKinematics k(m.pantograph->geometry);
  const auto x = handle(k, r);
  const double count = 2 * 3.141592653589793 / stage.axes[0].counts;
  EXPECT_NEAR(x(0), 0.01, 0.2 * count);  // |J| < 0.1 m/rad: a count moves the handle < 0.04 mm
  EXPECT_NEAR(x(1), 0.1, 0.2 * count);
}

TEST(LoopbackPantograph, AHandForceOnTheHandleMovesTheJointsByJTransposeF) {
  LoopbackDevice device(
      loopback::loopback_stage_from(keys({{"hand", "direction=1,1 mode=force force=2"}, {"counts", 1e12}})));
  device.configure({1e-3});
  const DeviceModel model = device.model();  // by value: a reference into it would dangle
  const auto& g = model.pantograph->geometry;
  const world::PantographKinematics k(g);
  std::array<Reading, 2> r{};
  ASSERT_EQ(device.read_axes(r), IoResult::ok);
  world::AxisVector q0(2);
  q0 << r[0].position, r[1].position;
  world::TaskState s;
  k.solve(q0, s);
  // One period of a constant torque on a resting rigid joint: dq = tau T^2 / (2 I).
  world::AxisVector f(2);
  f << std::sqrt(2.0), std::sqrt(2.0);  // 2 N along (1, 1) / sqrt 2
  const world::AxisVector tau = s.jacobian.transpose() * f;
  ASSERT_EQ(device.write_axes(std::array<double, 2>{0.0, 0.0}), IoResult::ok);
  ASSERT_EQ(device.read_axes(r), IoResult::ok);
  for (int i = 0; i < 2; ++i) {
    const double expected = tau(i) * 1e-6 / (2 * 5e-4);
    EXPECT_NEAR(r[static_cast<std::size_t>(i)].position - q0(i), expected, 1e-9 * std::abs(expected) + 1e-11)
        << "joint " << i + 1;
  }
  // The motors' torques add to the hand's: the same step with -tau written is rest.
  LoopbackDevice still(
      loopback::loopback_stage_from(keys({{"hand", "direction=1,1 mode=force force=2"}, {"counts", 1e12}})));
  still.configure({1e-3});
  ASSERT_EQ(still.write_axes(std::array<double, 2>{-tau(0), -tau(1)}), IoResult::ok);
  ASSERT_EQ(still.read_axes(r), IoResult::ok);
  EXPECT_NEAR(r[0].position, q0(0), 1e-12);
  EXPECT_NEAR(r[1].position, q0(1), 1e-12);
}

TEST(LoopbackPantograph, AHeldHandleFollowsItsReferenceAndWritingAllocatesNothing) {
  LoopbackDevice device(loopback::loopback_stage_from(
      keys({{"hand", "direction=0,-1 mode=hold trajectory=ramp from=0 to=0.02 rate=0.01"}})));
  device.configure({1e-3});
  const world::PantographKinematics k(device.model().pantograph->geometry);
  std::array<Reading, 2> r{};
  std::size_t allocations = 0;
  {
    hapticd::testing::AllocationGuard guard;
    for (int i = 0; i < 3000; ++i) {
      (void)device.read_axes(r);
      (void)device.write_axes(std::array<double, 2>{0.01, -0.01});  // the motors cannot move a held handle
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0U);
  ASSERT_EQ(device.read_axes(r), IoResult::ok);
  const auto x = handle(k, r);
  const double count = 2 * 3.141592653589793 / 16384;
  EXPECT_NEAR(x(0), 0.02, 0.2 * count) << "the workspace's centre, x";
  EXPECT_NEAR(x(1), 0.095 - 0.02, 0.2 * count) << "2 cm down the ramp";
}

TEST(LoopbackPantograph, LinkMassesWeighOnTheJointsAsMinusDVdqAndAllocateNothing) {
  const std::map<std::string, ParameterValue, std::less<>> weighted{
      {"link_masses", "0.02,0.03,0.03,0.02,0.01"}, {"counts", 1e12}};
  LoopbackDevice device(loopback::loopback_stage_from(keys(weighted)));
  device.configure({1e-3});
  const world::PantographKinematics k(device.model().pantograph->geometry);
  std::array<Reading, 2> r{};
  ASSERT_EQ(device.read_axes(r), IoResult::ok);
  world::AxisVector q0(2);
  q0 << r[0].position, r[1].position;
  world::TaskState s;
  k.solve(q0, s);
  const world::PantographMasses m{0.02, 0.03, 0.03, 0.02, 0.01};
  const world::AxisVector holding = world::pantograph_gravity_torques(k, m, q0, s);
  // One period from rest: dq = -tau_g T^2 / (2 I); the motors' +tau_g holds it.
  {
    hapticd::testing::AllocationGuard guard;
    ASSERT_EQ(device.write_axes(std::array<double, 2>{0.0, 0.0}), IoResult::ok);
    EXPECT_EQ(guard.count(), 0U);
  }
  ASSERT_EQ(device.read_axes(r), IoResult::ok);
  for (int i = 0; i < 2; ++i) {
    const double expected = -holding(i) * 1e-6 / (2 * 5e-4);
    EXPECT_NEAR(r[static_cast<std::size_t>(i)].position - q0(i), expected, 1e-9 * std::abs(expected) + 1e-11)
        << "joint " << i + 1;
  }
  LoopbackDevice held(loopback::loopback_stage_from(keys(weighted)));
  held.configure({1e-3});
  ASSERT_EQ(held.write_axes(std::array<double, 2>{holding(0), holding(1)}), IoResult::ok);
  ASSERT_EQ(held.read_axes(r), IoResult::ok);
  EXPECT_NEAR(r[0].position, q0(0), 1e-12);
  EXPECT_NEAR(r[1].position, q0(1), 1e-12);
  EXPECT_NE(held.model().description.find("vertical plane"), std::string::npos) << held.model().description;
}

TEST(LoopbackPantograph, HandSetActsOnTheHandleOrOnAJoint) {
  LoopbackDevice device(loopback::loopback_stage_from(keys({})));
  device.configure({1e-3});
  auto methods = device.methods();
  const auto& set = methods.at(0);
  ASSERT_EQ(set.name, "hand.set");
  auto answer = set.handler({{"mode", "impedance"}, {"stiffness", 200}, {"direction", "0,1"}});
  EXPECT_NE(answer["hand"].get<std::string>().find("direction=0,1"), std::string::npos) << answer.dump();
  EXPECT_EQ(answer["joints"][0], "mode=free");
  answer = set.handler({{"axis", 2}, {"mode", "force"}, {"force", 0.01}});
  EXPECT_NE(answer["joints"][1].get<std::string>().find("mode=force"), std::string::npos) << answer.dump();
  // A reference out of the linkage's reach is refused, naming the point.
  try {
    set.handler({{"mode", "hold"}, {"direction", "0,1"}, {"trajectory", "constant"}, {"position", 0.5}});
    ADD_FAILURE() << "a handle held 0.5 m away was accepted";
  } catch (const hapticd::rpc::RpcError& e) {
    EXPECT_NE(std::string(e.what()).find("out of the pantograph's reach"), std::string::npos) << e.what();
  }
}

TEST(LoopbackPantograph, RefusesWhatALinkageCannotTakeNamingTheKey) {
  EXPECT_NE(refusal({{"axes", 3.0}}).find("axes: "), std::string::npos);
  EXPECT_NE(refusal({{"axis_mass", "0.1,0.1"}}).find("joint_inertia"), std::string::npos);
  EXPECT_NE(refusal({{"motion", "linear"}}).find("motion: "), std::string::npos);
  EXPECT_NE(refusal({{"links", "0.07,0.09,0.09,0.07"}}).find("links: "), std::string::npos);
  const std::string far = refusal({{"workspace", "-0.02,0.06,0.07,0.3"}});
  EXPECT_NE(far.find("workspace: "), std::string::npos) << far;
  EXPECT_NE(far.find("out of reach"), std::string::npos) << far;
  EXPECT_NE(refusal({{"start", "0.5,0.1"}}).find("start: "), std::string::npos);
  EXPECT_NE(refusal({{"hand", "mode=impedance"}}).find("stiffness"), std::string::npos);
  EXPECT_NE(refusal({{"link_masses", "0.1,0.1,0.1,0.1"}}).find("link_masses: "), std::string::npos)
      << "four links and the handle: five masses";
  EXPECT_NE(refusal({{"link_masses", "0.1,0.1,-0.1,0.1,0"}}).find("link_masses: "), std::string::npos);
  const auto weighted = loopback::loopback_stage_from(keys({{"link_masses", "0.02,0.03,0.03,0.02,0.01"}}));
  ASSERT_TRUE(weighted.pantograph->weight.has_value());
  EXPECT_EQ(weighted.pantograph->weight->distal_right, 0.03);
  EXPECT_EQ(weighted.pantograph->weight->handle, 0.01);
  EXPECT_FALSE(loopback::loopback_stage_from(keys({})).pantograph->weight.has_value())
      << "weightless by default";
  // And a stage refuses the pantograph's keys.
  try {
    loopback::loopback_stage_from(DriverParameters("loopback", loopback::loopback_parameters(),
                                                   {{"axes", 2.0}, {"links", "1,1,1,1,1"}}));
    ADD_FAILURE() << "links accepted on a stage";
  } catch (const ParameterError& e) {
    EXPECT_EQ(e.key(), "links");
  }
}

}  // namespace loopback_pantograph_test
