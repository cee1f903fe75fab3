// Several axes through the framework (issue 22): the Device's read_axes /
// write_axes (the same lifecycle checks and counting as read / write, one
// call for every axis), the hooks' defaults for a one-axis driver, and the
// loopback's Cartesian stage (one plant simulator per axis, its own mass,
// damping and hand; axes = 1 exactly today's loopback).

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "drivers/device.hpp"
#include "drivers/loopback/loopback_config.hpp"
#include "drivers/loopback/loopback_device.hpp"
#include "rpc/jsonrpc.hpp"
#include "tests/support/alloc_counter.hpp"

namespace device_axes_test {

namespace {

using namespace hapticd::drivers;
using hapticd::drivers::loopback::LoopbackConfig;
using hapticd::drivers::loopback::LoopbackDevice;
using hapticd::drivers::loopback::LoopbackStage;

/// A one-axis test driver: read and write only (the defaults do the rest).
class OneAxisHooks final : public DeviceHooks {
 public:
  IoResult read(Reading& out) noexcept override {
    out.position = 0.125;
    return IoResult::ok;
  }
  IoResult write(double force) noexcept override {
    last_force = force;
    return IoResult::ok;
  }
  DeviceModel model() const override { return {}; }
  double last_force = 0.0;
};

/// A three-axis test driver whose per-call results are scripted.
class ThreeAxisHooks final : public DeviceHooks {
 public:
  IoResult read(Reading&) noexcept override { return IoResult::ok; }
  IoResult write(double) noexcept override { return IoResult::ok; }
  int axes() const noexcept override { return 3; }
  IoResult read_axes(std::span<Reading> out) noexcept override {
    ++reads;
    for (std::size_t i = 0; i < out.size(); ++i) out[i].position = 0.1 * static_cast<double>(i + 1);
    return next_read;
  }
  IoResult write_axes(std::span<const double> forces) noexcept override {
    ++writes;
    for (std::size_t i = 0; i < forces.size(); ++i) last[i] = forces[i];
    return next_write;
  }
  DeviceModel model() const override { return {}; }
  int reads = 0, writes = 0;
  std::array<double, 3> last{};
  IoResult next_read = IoResult::ok, next_write = IoResult::ok;
};

class BadAxesHooks final : public DeviceHooks {
 public:
  explicit BadAxesHooks(int n) : n_(n) {}
  IoResult read(Reading&) noexcept override { return IoResult::ok; }
  IoResult write(double) noexcept override { return IoResult::ok; }
  int axes() const noexcept override { return n_; }
  DeviceModel model() const override { return {}; }

 private:
  int n_;
};

TEST(DeviceAxes, AOneAxisDriverIsReadAndWrittenThroughTheDefaults) {
  Device device("scripted", std::make_unique<OneAxisHooks>());
  EXPECT_EQ(device.axes(), 1);
  device.configure({1e-3});
  device.enable();
  std::array<Reading, 1> r{};
  ASSERT_EQ(device.read_axes(r), IoResult::ok);
  EXPECT_EQ(r[0].position, 0.125);
  const std::array<double, 1> f{0.75};
  ASSERT_EQ(device.write_axes(f), IoResult::ok);
  EXPECT_EQ(device.hooks_as<OneAxisHooks>().last_force, 0.75);
  std::array<Reading, 2> two{};
  EXPECT_EQ(device.read_axes(two), IoResult::error) << "one entry per axis";
  EXPECT_EQ(device.status().read_errors, 1U);
}

TEST(DeviceAxes, SeveralAxesAreReadAndWrittenInOneCallWithTheLifecycleAndCounting) {
  Device device("stage", std::make_unique<ThreeAxisHooks>());
  auto& hooks = device.hooks_as<ThreeAxisHooks>();
  EXPECT_EQ(device.axes(), 3);
  std::array<Reading, 3> r{};
  const std::array<double, 3> f{1.0, -2.0, 3.0};
  EXPECT_EQ(device.read_axes(r), IoResult::error) << "before configure()";
  device.configure({1e-3});
  EXPECT_EQ(device.write_axes(f), IoResult::error) << "before enable()";
  device.enable();
  ASSERT_EQ(device.read_axes(r), IoResult::ok);
  EXPECT_DOUBLE_EQ(r[2].position, 0.3);
  ASSERT_EQ(device.write_axes(f), IoResult::ok);
  EXPECT_EQ(hooks.last, f);
  EXPECT_EQ(hooks.reads, 1) << "one hook call for every axis";
  EXPECT_EQ(hooks.writes, 1);
  Reading one;
  EXPECT_EQ(device.read(one), IoResult::error) << "one axis of several is never read alone";
  EXPECT_EQ(device.write(0.5), IoResult::error);
  std::array<Reading, 2> short_read{};
  EXPECT_EQ(device.read_axes(short_read), IoResult::error);
  EXPECT_EQ(hooks.reads, 1) << "refused before the hook";
  hooks.next_read = IoResult::fault;
  EXPECT_EQ(device.read_axes(r), IoResult::fault);
  EXPECT_EQ(device.read_axes(r), IoResult::fault);
  hooks.next_write = IoResult::error;
  EXPECT_EQ(device.write_axes(f), IoResult::error);
  const DeviceStatus s = device.status();
  EXPECT_EQ(s.read_errors, 3U) << "before configure, read(), the short span";
  EXPECT_EQ(s.write_errors, 3U) << "before enable, write(), the scripted error";
  EXPECT_EQ(s.faults, 1U) << "once per latch";
  EXPECT_EQ(s.state, DeviceState::fault);
}

TEST(DeviceAxes, ADriverSayingNoAxesOrTooManyIsRefused) {
  EXPECT_THROW(Device("zero", std::make_unique<BadAxesHooks>(0)), std::invalid_argument);
  try {
    Device("seven", std::make_unique<BadAxesHooks>(7));
    ADD_FAILURE();
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "seven: a device has 1 to 6 axes; its driver says 7");
  }
}

TEST(DeviceAxes, SixAxesAllocateNothing) {
  ASSERT_TRUE(hapticd::testing::allocation_counting_active());
  LoopbackStage stage;
  for (int i = 0; i < 6; ++i) {
    stage.axes.push_back(LoopbackConfig::defaults(Motion::linear));
    stage.hands.emplace_back();
  }
  Device device("loopback", std::make_unique<LoopbackDevice>(stage));
  device.configure({1e-3});
  device.enable();
  std::array<Reading, 6> r{};
  std::array<double, 6> f{0.1, 0.2, 0.3, 0.4, 0.5, 0.6};
  int ok = 0;
  std::size_t allocations = 0;
  {
    hapticd::testing::AllocationGuard guard;
    for (int i = 0; i < 1000; ++i) {
      ok += device.read_axes(r) == IoResult::ok;
      ok += device.write_axes(f) == IoResult::ok;
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0U);
  EXPECT_EQ(ok, 2000);
}

// ---- the loopback's stage ----

DriverParameters loopback_keys(std::map<std::string, ParameterValue, std::less<>> given) {
  return DriverParameters("loopback", loopback::loopback_parameters(), given);
}

TEST(LoopbackStage, AxesOneOrAbsentIsExactlyTodaysLoopback) {
  const auto absent = loopback::loopback_stage_from(loopback_keys({{"motion", "linear"}, {"mass", 0.2}}));
  const auto one =
      loopback::loopback_stage_from(loopback_keys({{"motion", "linear"}, {"mass", 0.2}, {"axes", 1.0}}));
  ASSERT_EQ(absent.axes.size(), 1U);
  ASSERT_EQ(one.axes.size(), 1U);
  const LoopbackConfig today = loopback::parse_loopback_config("motion=linear mass=0.2");
  EXPECT_EQ(absent.axes[0].mass, today.mass);
  EXPECT_EQ(absent.axes[0].counts, today.counts);
  EXPECT_EQ(absent.axes[0].motion, today.motion);
  // Sample by sample against the one-axis constructor, under a hand.
  const auto hand = hapticd::drivers::simulation::parse_hand_script("mode=force force=0.3");
  LoopbackDevice stage_device(LoopbackStage{{today}, {hand}, std::nullopt});
  LoopbackDevice today_device(today, hand);
  stage_device.configure({1e-3});
  today_device.configure({1e-3});
  EXPECT_EQ(stage_device.axes(), 1);
  for (int i = 0; i < 200; ++i) {
    Reading a, b;
    ASSERT_EQ(stage_device.read(a), IoResult::ok);
    ASSERT_EQ(today_device.read(b), IoResult::ok);
    ASSERT_EQ(a.position, b.position) << "period " << i;
    (void)stage_device.write(0.01 * i);
    (void)today_device.write(0.01 * i);
  }
  EXPECT_TRUE(stage_device.model().axes.empty()) << "one axis: today's model fields";
}

TEST(LoopbackStage, EachAxisIsItsOwnPlantWithItsMassDampingAndHand) {
  const auto stage = loopback::loopback_stage_from(loopback_keys({{"axes", 2.0},
                                                                  {"axis_mass", "0.1, 0.3"},
                                                                  {"axis_damping", "0,2"},
                                                                  {"counts", 1e9},
                                                                  {"hands", "mode=free; mode=free"}}));
  ASSERT_EQ(stage.axes.size(), 2U);
  EXPECT_EQ(stage.axes[0].motion, Motion::linear)
      << "a stage is linear unless told otherwise (it refuses rotary)";
  LoopbackDevice device(stage);
  device.configure({1e-3});
  device.enable();
  EXPECT_EQ(device.axes(), 2);
  // The same force on both axes for 0.1 s: x = F t^2 / (2 m) on the undamped axis.
  const std::array<double, 2> f{1.0, 1.0};
  std::array<Reading, 2> r{};
  for (int i = 0; i < 100; ++i) ASSERT_EQ(device.write_axes(f), IoResult::ok);
  ASSERT_EQ(device.read_axes(r), IoResult::ok);
  EXPECT_NEAR(r[0].position, 1.0 * 0.01 / (2 * 0.1), 2e-9);
  const double c = 2.0 / 0.3;  // b / m, x = F/b (t - (1 - e^{-c t}) / c)
  EXPECT_NEAR(r[1].position, 1.0 / 2.0 * (0.1 - (1.0 - std::exp(-c * 0.1)) / c), 2e-9);
  const DeviceModel m = device.model();
  ASSERT_EQ(m.axes.size(), 2U);
  EXPECT_EQ(m.axes[1].mass, 0.3);
  EXPECT_EQ(m.axes[1].damping, 2.0);
  EXPECT_EQ(m.effective_mass, 0.1) << "the lightest axis in the one-axis fields";
  EXPECT_EQ(m.motion, Motion::linear);
}

TEST(LoopbackStage, HandsAreScriptedPerAxis) {
  const auto stage = loopback::loopback_stage_from(
      loopback_keys({{"axes", 2.0},
                     {"counts", 1e9},
                     {"hands", "mode=hold trajectory=ramp from=0 to=0.01 rate=0.1 at=0; mode=hold"}}));
  LoopbackDevice device(stage);
  device.configure({1e-3});
  device.enable();
  const std::array<double, 2> f{0.0, 0.0};
  std::array<Reading, 2> r{};
  for (int i = 0; i < 200; ++i) (void)device.write_axes(f);
  ASSERT_EQ(device.read_axes(r), IoResult::ok);
  EXPECT_NEAR(r[0].position, 0.01, 1e-9) << "the ramp held x at its end";
  EXPECT_NEAR(r[1].position, 0.0, 1e-9) << "y held at 0";
  // hand.set with an axis changes that axis only.
  auto methods = device.methods();
  ASSERT_EQ(methods[0].name, "hand.set");
  const auto reply = methods[0].handler(nlohmann::json{{"axis", 2}, {"text", "mode=free"}});
  ASSERT_EQ(reply["hands"].size(), 2U);
  EXPECT_EQ(reply["hands"][1], "mode=free");
  EXPECT_NE(reply["hands"][0], "mode=free");
  EXPECT_THROW(methods[0].handler(nlohmann::json{{"axis", 3}, {"text", "mode=free"}}),
               hapticd::rpc::RpcError);
  // fault.inject on one axis: the whole read says so.
  (void)methods[1].handler(nlohmann::json{{"kind", "read-error"}, {"axis", 2}, {"amount", 1}});
  EXPECT_EQ(device.read_axes(r), IoResult::error);
}

TEST(LoopbackStage, BadKeysAreRefusedNamingTheKeyAndWhatIsAccepted) {
  const auto refused =
      [](std::map<std::string, ParameterValue, std::less<>> given) -> std::pair<std::string, std::string> {
    try {
      (void)loopback::loopback_stage_from(loopback_keys(std::move(given)));
    } catch (const ParameterError& e) {
      return {e.key(), e.what()};
    }
    return {"", "accepted"};
  };
  auto [key, text] = refused({{"axes", 2.0}, {"axis_mass", "0.1"}});
  EXPECT_EQ(key, "axis_mass");
  EXPECT_NE(text.find("2 comma-separated numbers from 1e-09 to 1e+06 (kg)"), std::string::npos) << text;
  std::tie(key, text) = refused({{"axes", 2.0}, {"axis_damping", "1,-1"}});
  EXPECT_EQ(key, "axis_damping");
  std::tie(key, text) = refused({{"axes", 2.0}, {"axis_mass", "0.1,nan"}});
  EXPECT_EQ(key, "axis_mass");
  std::tie(key, text) = refused({{"axes", 3.0}, {"hands", "mode=free; mode=free"}});
  EXPECT_EQ(key, "hands");
  EXPECT_NE(text.find("one per axis (3)"), std::string::npos) << text;
  std::tie(key, text) = refused({{"axes", 2.0}, {"hands", "mode=fly; mode=free"}});
  EXPECT_EQ(key, "hands");
  EXPECT_NE(text.find("axis 1"), std::string::npos) << text;
  std::tie(key, text) = refused({{"axes", 2.0}, {"motion", "rotary"}});
  EXPECT_EQ(key, "motion");
  std::tie(key, text) = refused({{"axes", 2.0}, {"plant", "two-mass"}});
  EXPECT_EQ(key, "plant");
  std::tie(key, text) = refused({{"axis_mass", "0.1,0.2"}});
  EXPECT_EQ(key, "axis_mass") << "a one-axis loopback takes mass";
  EXPECT_THROW((void)loopback_keys({{"axes", 7.0}}), ParameterError);
  EXPECT_THROW((void)loopback_keys({{"axes", 0.0}}), ParameterError);
}

}  // namespace

}  // namespace device_axes_test
