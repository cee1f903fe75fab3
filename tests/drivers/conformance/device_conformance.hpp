#pragma once
/// \file
/// The conformance suite every driver passes through the framework's Device
/// (DRIVERS.md "Evidence every driver gives"): its hooks work in the
/// lifecycle's order, allocation-free read()/write(), disable() zeroes the
/// output, a device fault latches until clear_fault(), close() is
/// idempotent, bad parameters are refused naming the key. The order
/// itself is the framework's, tested once (tests/drivers/device_test.cpp).
///
/// A driver adds itself with a fixture and one line, in its own test binary
/// (which links hapticd_alloc_counter):
///
///   struct CanopenConformance { ... the members below ... };
///   INSTANTIATE_TYPED_TEST_SUITE_P(Canopen, DeviceConformance, CanopenConformance);
///
/// Fixture members:
///   static constexpr const char* driver;          // registry name
///   std::map<...> parameters();                    // a valid [device.<driver>] table (peer running)
///   double period_s();
///   void inject_device_fault(drivers::Device&);    // the peer goes to fault with a reason
///   double observed_output(drivers::Device&);      // force/torque the peer applies now (SI)
/// (device.hooks_as<TheDriversHooks>() reaches the driver's own object.)
///   std::vector<BadParameters> bad_parameters();   // refused tables and the key each must name

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "drivers/registry.hpp"
#include "tests/support/alloc_counter.hpp"

namespace hapticd::testing {

using ParameterTable = std::map<std::string, drivers::ParameterValue, std::less<>>;

struct BadParameters {
  ParameterTable parameters;
  std::string key;  ///< what the error must name (ParameterError::key() or DeviceError::key())
};

/// Builds a device through the registry, as the daemon does.
inline std::unique_ptr<drivers::Device> make_device(const char* driver, const ParameterTable& table) {
  const auto* description = drivers::find_driver(driver);
  if (description == nullptr || !description->ready)
    throw std::logic_error("no ready driver " + std::string(driver));
  return drivers::make_device(*description,
                              drivers::DriverParameters(driver, description->parameters, table));
}

/// The key a refused table names: building it (factory and configure) must throw.
template <class Fixture>
std::string refused_key(Fixture& fixture, const ParameterTable& table) {
  try {
    auto device = make_device(Fixture::driver, table);
    device->configure({fixture.period_s()});
  } catch (const drivers::ParameterError& e) {
    return e.key();
  } catch (const drivers::DeviceError& e) {
    return e.key();
  }
  return "<accepted>";
}

template <class Fixture>
class DeviceConformance : public ::testing::Test {
 protected:
  std::unique_ptr<drivers::Device> make() { return make_device(Fixture::driver, fixture.parameters()); }
  void enable(drivers::Device& device) {
    device.configure({fixture.period_s()});
    device.enable();
  }
  Fixture fixture;
};

TYPED_TEST_SUITE_P(DeviceConformance);

// The order itself (what is refused when, with logic_error) is the
// framework's, tested once in tests/drivers/device_test.cpp; here each driver
// shows that its hooks deliver in that order.
TYPED_TEST_P(DeviceConformance, LifecycleStepsWorkInOrder) {
  auto device = this->make();
  drivers::Reading r;
  EXPECT_EQ(device->status().state, drivers::DeviceState::closed);
  device->configure({this->fixture.period_s()});
  EXPECT_EQ(device->status().state, drivers::DeviceState::configured);
  EXPECT_EQ(device->read(r), drivers::IoResult::ok) << "read() is valid from configure() on";
  EXPECT_TRUE(std::isfinite(r.position));
  (void)device->model();  // valid from configure() on
  device->enable();
  EXPECT_EQ(device->status().state, drivers::DeviceState::enabled);
  EXPECT_EQ(device->read(r), drivers::IoResult::ok);
  EXPECT_EQ(device->write(0.0), drivers::IoResult::ok);
  device->disable();
  EXPECT_EQ(device->status().state, drivers::DeviceState::configured);
  device->enable();  // again, as after a clear
  EXPECT_EQ(device->read(r), drivers::IoResult::ok);
  EXPECT_EQ(device->write(0.0), drivers::IoResult::ok);
  device->close();
  EXPECT_EQ(device->status().state, drivers::DeviceState::closed);
}

TYPED_TEST_P(DeviceConformance, ReadAndWriteAllocateNothing) {
  ASSERT_TRUE(allocation_counting_active()) << "link hapticd_alloc_counter into this test binary";
  auto device = this->make();
  this->enable(*device);
  drivers::Reading r;
  std::size_t allocations = 0;
  int failures = 0;
  {
    AllocationGuard guard;
    for (int i = 0; i < 1000; ++i) {
      failures += device->read(r) != drivers::IoResult::ok;
      failures += device->write(1e-3 * std::sin(0.01 * i)) != drivers::IoResult::ok;
    }
    allocations = guard.count();  // before any gtest macro allocates
  }
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(failures, 0);
  device->close();
}

TYPED_TEST_P(DeviceConformance, DisableZeroesTheOutput) {
  auto device = this->make();
  this->enable(*device);
  drivers::Reading r;
  for (int i = 0; i < 20; ++i) {
    ASSERT_EQ(device->read(r), drivers::IoResult::ok);
    ASSERT_EQ(device->write(0.05), drivers::IoResult::ok);
  }
  EXPECT_NE(this->fixture.observed_output(*device), 0.0) << "the peer never saw the command";
  device->disable();
  EXPECT_EQ(this->fixture.observed_output(*device), 0.0);
  device->close();
}

TYPED_TEST_P(DeviceConformance, DeviceFaultLatchesUntilCleared) {
  auto device = this->make();
  this->enable(*device);
  drivers::Reading r;
  ASSERT_EQ(device->read(r), drivers::IoResult::ok);
  ASSERT_EQ(device->write(0.0), drivers::IoResult::ok);
  this->fixture.inject_device_fault(*device);
  // Seen within a few periods, then it stays: a fault latches.
  int seen_at = -1;
  for (int i = 0; i < 50 && seen_at < 0; ++i) {
    const bool faulted = device->read(r) == drivers::IoResult::fault;
    if (device->write(0.0) == drivers::IoResult::fault || faulted) seen_at = i;
  }
  ASSERT_GE(seen_at, 0) << "the injected fault was never reported";
  for (int i = 0; i < 20; ++i) {
    const bool read_fault = device->read(r) == drivers::IoResult::fault;
    const bool write_fault = device->write(0.0) == drivers::IoResult::fault;
    EXPECT_TRUE(read_fault || write_fault) << "fault cleared by itself after " << i << " periods";
  }
  EXPECT_EQ(device->status().state, drivers::DeviceState::fault);
  EXPECT_FALSE(device->status().fault_reason.empty()) << "a fault says the device's reason";
  const std::string cleared = device->clear_fault();
  EXPECT_FALSE(cleared.empty()) << "clear_fault() says what it cleared";
  bool ok = false;
  for (int i = 0; i < 50 && !ok; ++i) {
    ok = device->read(r) == drivers::IoResult::ok && device->write(0.0) == drivers::IoResult::ok;
  }
  EXPECT_TRUE(ok) << "still in fault after clear_fault()";
  EXPECT_EQ(device->status().state, drivers::DeviceState::enabled);
  device->close();
}

TYPED_TEST_P(DeviceConformance, CloseIsIdempotent) {
  auto device = this->make();
  device->close();  // never configured
  device->close();
  auto second = this->make();
  this->enable(*second);
  second->close();
  second->close();
  EXPECT_EQ(second->status().state, drivers::DeviceState::closed);
}

TYPED_TEST_P(DeviceConformance, BadParametersAreRefusedNamingTheKey) {
  const auto cases = this->fixture.bad_parameters();
  ASSERT_FALSE(cases.empty());
  for (const auto& c : cases) EXPECT_EQ(refused_key(this->fixture, c.parameters), c.key);
  ParameterTable unknown = this->fixture.parameters();
  unknown["no_such_key"] = 1.0;
  EXPECT_EQ(refused_key(this->fixture, unknown), "no_such_key");
}

REGISTER_TYPED_TEST_SUITE_P(DeviceConformance, LifecycleStepsWorkInOrder, ReadAndWriteAllocateNothing,
                            DisableZeroesTheOutput, DeviceFaultLatchesUntilCleared, CloseIsIdempotent,
                            BadParametersAreRefusedNamingTheKey);

}  // namespace hapticd::testing
