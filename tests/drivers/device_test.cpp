// The framework's Device around a driver's hooks (drivers/device.hpp): the
// lifecycle order, error translation, error and fault counting and the
// clear-fault contract, tested once here for every driver. The drivers'
// own behaviour is the conformance suite's (conformance/device_conformance.hpp).

#include "drivers/device.hpp"

#include <gtest/gtest.h>

#include <memory>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

#include "tests/support/alloc_counter.hpp"

namespace device_test {

namespace {

using namespace hapticd::drivers;

/// A driver with the hooks a test component needs and nothing else
/// (ros2_control's test component): read, write and the model.
class ScriptedHooks final : public DeviceHooks {
 public:
  IoResult read(Reading& out) noexcept override {
    out.position = position;
    return next_read;
  }
  IoResult write(double force) noexcept override {
    last_force = force;
    return next_write;
  }
  DeviceModel model() const override { return {}; }

  double position = 0.25, last_force = 0.0;
  IoResult next_read = IoResult::ok, next_write = IoResult::ok;
};

/// Every hook recorded, and each lifecycle step made to fail on demand.
class RecordingHooks final : public DeviceHooks {
 public:
  void configure(const LoopContext&) override { step("configure"); }
  void enable() override { step("enable"); }
  std::string clear_fault() override {
    step("clear_fault");
    return "reset";
  }
  void disable() noexcept override { calls.push_back("disable"); }
  void close() noexcept override { calls.push_back("close"); }
  IoResult read(Reading&) noexcept override { return IoResult::ok; }
  IoResult write(double) noexcept override { return IoResult::ok; }
  DeviceModel model() const override { return {}; }
  DeviceHealth health() const override {
    return {faulted, faulted ? "over current" : "", "", {{"frames", 7}}};
  }

  std::vector<std::string> calls;
  std::string fail_step;  ///< the step that throws
  enum class How { device_error, system_error, stop } how = How::device_error;
  bool faulted = false;

 private:
  void step(const std::string& name) {
    calls.push_back(name);
    if (name != fail_step) return;
    switch (how) {
      case How::device_error:
        throw DeviceError("scripted: " + name + " failed at 3 frames", "bitrate");
      case How::system_error:
        throw std::system_error(ENODEV, std::generic_category(), "opening can0");
      case How::stop:
        throw StopRequested("scripted: stopped during " + name);
    }
  }
};

struct Rig {
  Rig() : owned(new RecordingHooks), hooks(*owned), device("scripted", std::unique_ptr<DeviceHooks>(owned)) {}
  RecordingHooks* owned;
  RecordingHooks& hooks;
  Device device;
};

TEST(Device, LifecycleOrderIsEnforcedOnceForEveryDriver) {
  Device device("scripted", std::make_unique<ScriptedHooks>());
  Reading r;
  EXPECT_EQ(device.status().state, DeviceState::closed);
  EXPECT_EQ(device.read(r), IoResult::error) << "read() before configure()";
  EXPECT_EQ(device.write(0.0), IoResult::error) << "write() before configure()";
  EXPECT_THROW(device.enable(), std::logic_error) << "enable() before configure()";
  EXPECT_THROW(device.clear_fault(), std::logic_error) << "clear_fault() before configure()";
  EXPECT_THROW((void)device.model(), std::logic_error) << "model() before configure()";
  device.configure({1e-3});
  EXPECT_EQ(device.status().state, DeviceState::configured);
  try {
    device.configure({1e-3});
    ADD_FAILURE() << "configure() twice";
  } catch (const std::logic_error& e) {
    EXPECT_STREQ(e.what(), "scripted: configure() while configured");
  }
  EXPECT_EQ(device.read(r), IoResult::ok);
  EXPECT_EQ(r.position, 0.25);
  EXPECT_EQ(device.write(0.0), IoResult::error) << "write() before enable()";
  device.enable();
  EXPECT_EQ(device.status().state, DeviceState::enabled);
  EXPECT_EQ(device.write(0.5), IoResult::ok);
  EXPECT_EQ(device.hooks_as<ScriptedHooks>().last_force, 0.5);
  device.disable();
  EXPECT_EQ(device.status().state, DeviceState::configured);
  EXPECT_EQ(device.write(0.0), IoResult::error) << "write() after disable()";
  device.enable();  // again, as after a clear
  EXPECT_EQ(device.write(0.0), IoResult::ok);
  device.close();
  EXPECT_EQ(device.status().state, DeviceState::closed);
  EXPECT_EQ(device.read(r), IoResult::error) << "read() after close()";
  const DeviceStatus s = device.status();
  EXPECT_EQ(s.read_errors, 2U) << "the refused reads are counted";
  EXPECT_EQ(s.write_errors, 3U) << "the refused writes are counted";
}

TEST(Device, EachHookRunsOnlyInItsStateAndCloseOnce) {
  Rig rig;
  rig.device.close();  // never configured: no hook
  rig.device.disable();
  EXPECT_TRUE(rig.hooks.calls.empty());
  rig.device.configure({1e-3});
  rig.device.disable();  // not enabled: no hook
  rig.device.enable();
  rig.device.enable();
  rig.device.close();
  rig.device.close();
  EXPECT_EQ(rig.hooks.calls, (std::vector<std::string>{"configure", "enable", "enable", "disable", "close"}));
}

TEST(Device, ADeviceErrorPassesWithItsKeyAndIsKeptForStatus) {
  Rig rig;
  rig.hooks.fail_step = "configure";
  try {
    rig.device.configure({1e-3});
    ADD_FAILURE() << "configure() did not throw";
  } catch (const DeviceError& e) {
    EXPECT_STREQ(e.what(), "scripted: configure failed at 3 frames");
    EXPECT_EQ(e.key(), "bitrate");
  }
  EXPECT_EQ(rig.device.status().state, DeviceState::closed);
  EXPECT_EQ(rig.device.status().last_error, "scripted: configure failed at 3 frames");
  EXPECT_EQ(rig.hooks.calls, (std::vector<std::string>{"configure", "close"}))
      << "what the failed configure opened is closed";
}

TEST(Device, AnyOtherExceptionBecomesADeviceErrorNamingTheDriverAndTheStep) {
  Rig rig;
  rig.hooks.fail_step = "configure";
  rig.hooks.how = RecordingHooks::How::system_error;
  try {
    rig.device.configure({1e-3});
    ADD_FAILURE() << "configure() did not throw";
  } catch (const DeviceError& e) {
    EXPECT_EQ(std::string(e.what()), "scripted: configure: opening can0: No such device");
    EXPECT_EQ(e.key(), "");
  }
}

TEST(Device, AStopRequestPassesUnchanged) {
  Rig rig;
  rig.hooks.fail_step = "enable";
  rig.hooks.how = RecordingHooks::How::stop;
  rig.device.configure({1e-3});
  EXPECT_THROW(rig.device.enable(), StopRequested);
  EXPECT_EQ(rig.device.status().state, DeviceState::configured);
  EXPECT_EQ(rig.hooks.calls, (std::vector<std::string>{"configure", "enable", "disable"}))
      << "a failed enable leaves the power stage off";
}

TEST(Device, FaultsAreCountedOncePerLatchAndClearOnlyWhenTheHookSucceeds) {
  Device device("scripted", std::make_unique<ScriptedHooks>());
  auto& hooks = device.hooks_as<ScriptedHooks>();
  device.configure({1e-3});
  device.enable();
  Reading r;
  hooks.next_read = IoResult::fault;
  for (int i = 0; i < 5; ++i) EXPECT_EQ(device.read(r), IoResult::fault);
  EXPECT_EQ(device.status().faults, 1U) << "one fault, reported every period until cleared";
  EXPECT_EQ(device.status().state, DeviceState::fault);
  EXPECT_EQ(device.status().read_errors, 0U) << "a fault is not a transient error";
  hooks.next_read = IoResult::ok;
  EXPECT_EQ(device.clear_fault(), "");
  EXPECT_EQ(device.status().state, DeviceState::enabled);
  hooks.next_write = IoResult::fault;
  EXPECT_EQ(device.write(0.0), IoResult::fault);
  EXPECT_EQ(device.status().faults, 2U);
  hooks.next_write = IoResult::error;
  EXPECT_EQ(device.write(0.0), IoResult::error);
  EXPECT_EQ(device.status().write_errors, 1U);
}

TEST(Device, AFailedClearKeepsTheLatch) {
  Rig rig;
  rig.device.configure({1e-3});
  rig.device.enable();
  rig.hooks.faulted = true;
  EXPECT_EQ(rig.device.status().state, DeviceState::fault) << "the device's own latch";
  EXPECT_EQ(rig.device.status().fault_reason, "over current");
  rig.hooks.fail_step = "clear_fault";
  EXPECT_THROW(rig.device.clear_fault(), DeviceError);
  EXPECT_EQ(rig.device.status().state, DeviceState::fault);
  rig.hooks.fail_step.clear();
  rig.hooks.faulted = false;
  EXPECT_EQ(rig.device.clear_fault(), "reset");
  EXPECT_EQ(rig.device.status().state, DeviceState::enabled);
  ASSERT_EQ(rig.device.status().counters.size(), 1U);
  EXPECT_EQ(rig.device.status().counters[0].name, "frames");
}

TEST(Device, TheRtCallsAllocateNothing) {
  ASSERT_TRUE(hapticd::testing::allocation_counting_active());
  Device device("scripted", std::make_unique<ScriptedHooks>());
  auto& hooks = device.hooks_as<ScriptedHooks>();
  device.configure({1e-3});
  device.enable();
  Reading r;
  int ok = 0;
  std::size_t allocations = 0;
  {
    hapticd::testing::AllocationGuard guard;
    for (int i = 0; i < 1000; ++i) {
      hooks.next_read = i % 100 == 50 ? IoResult::fault : i % 7 == 0 ? IoResult::error : IoResult::ok;
      ok += device.read(r) == IoResult::ok;
      ok += device.write(0.1) == IoResult::ok;
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0U);
  // 142 errors (143 multiples of 7, one of them 350, a fault) and 10 faults.
  EXPECT_EQ(ok, 1000 + 1000 - 142 - 10) << "every write and the reads scripted ok";
}

}  // namespace

}  // namespace device_test
