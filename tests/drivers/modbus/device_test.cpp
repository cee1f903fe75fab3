// The modbus Device against the simulated amplifier, over TCP and RTU (pty):
// lifecycle, the one-period delay (a run equals the loopback run with
// delay = 1, sample by sample), every failure latched with the amplifier's
// own reason and cleared on the amplifier, the watchdog, the budget
// refusals, and an RT path without allocation.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "c_alloc_counter.hpp"
#include "drivers/device.hpp"
#include "drivers/modbus/modbus_device.hpp"
#include "drivers/simulation/plant_simulator.hpp"
#include "drivers/stop_request.hpp"
#include "hostile_server.hpp"
#include "loopback_plant.hpp"
#include "sim/modbus/amplifier_server.hpp"
#include "tests/support/alloc_counter.hpp"

namespace device_test {

namespace mb = hapticd::drivers::modbus;
using hapticd::drivers::DeviceError;
using hapticd::drivers::DeviceState;
using hapticd::drivers::IoResult;
using hapticd::drivers::LoopContext;
using hapticd::drivers::Reading;
using hapticd::drivers::StopRequest;
using hapticd::drivers::StopRequested;
using Values = std::map<std::string, hapticd::drivers::ParameterValue, std::less<>>;

namespace {

// A 50 ms period with most of it for the link, and a 1 s watchdog: the
// transactions here never time out and the watchdog never expires unless a
// test makes them (the VM's vCPU stalls for ms, more under load).
constexpr double test_period_s = 50e-3;

mb::sim::AmplifierSettings amplifier_settings(const mb::ModbusConfig& c) {
  mb::sim::AmplifierSettings s;
  s.position_per_count = c.position_per_count();
  s.torque_per_count = c.torque_per_count;
  s.function_23 = true;
  return s;
}

std::string text(const std::exception& e) { return e.what(); }

/// Waits, bounded, for what a test expects to happen: true as soon as it
/// has, false after 10 s without it.
template <class Condition>
bool eventually(Condition condition) {
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!condition() && std::chrono::steady_clock::now() < give_up)
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  return condition();
}

class DeviceTest : public ::testing::TestWithParam<mb::Transport> {
 protected:
  DeviceTest() : amplifier_config_(mb::modbus_config({})) {}
  ~DeviceTest() override {
    device_.reset();
    if (server_) server_->stop();
  }

  bool rtu() const { return GetParam() == mb::Transport::rtu; }

  /// before_start: runs on this thread before the server's thread exists
  /// (Amplifier::tick() is that thread's once it runs).
  /// on_clock: the amplifier's watchdog runs on clock_, which the test advances.
  void start_amplifier(mb::sim::AmplifierSettings settings, const std::function<void()>& before_start = {},
                       bool on_clock = false) {
    amplifier_ = std::make_unique<mb::sim::Amplifier>(settings, plant_);
    if (before_start) before_start();
    server_ =
        rtu() ? mb::sim::AmplifierServer::rtu_pty(*amplifier_) : mb::sim::AmplifierServer::tcp(*amplifier_);
    if (on_clock) server_->use_clock(clock_);
    server_->start();
    (void)server_->make_realtime(70);  // as an amplifier is its own hardware, when permitted
  }

  mb::ModbusConfig device_config(Values values = {}) {
    values.emplace("transport", std::string(rtu() ? "rtu" : "tcp"));
    values.emplace("link_budget", 0.9);
    values.emplace("rtt_samples", 20.0);
    values.emplace("watchdog_value", 1000.0);
    if (rtu()) {
      values.emplace("device", server_->slave_path());
      values.emplace("silence", std::string("characters"));
      values.emplace("baud", 4000000.0);
    } else {
      values.emplace("port", static_cast<double>(server_->port()));
    }
    return mb::modbus_config(values);
  }

  hapticd::drivers::Device& configure(Values values = {}) {
    if (!amplifier_) start_amplifier(amplifier_settings(amplifier_config_));
    device_ = std::make_unique<hapticd::drivers::Device>(
        "modbus", std::make_unique<mb::ModbusDevice>(device_config(std::move(values))));
    device_->configure(LoopContext{test_period_s, stop_.token()});
    return *device_;
  }

  hapticd::drivers::Device& enabled(Values values = {}) {
    configure(std::move(values)).enable();
    return *device_;
  }

  hapticd::drivers::StopRequest stop_;  ///< the daemon's stop, as configure() gets it
  mb::sim::ManualClock clock_;          ///< the amplifier's time, when the test runs it
  mb::ModbusConfig amplifier_config_;
  mb::testing::LoopbackPlant plant_;
  std::unique_ptr<mb::sim::Amplifier> amplifier_;
  std::unique_ptr<mb::sim::AmplifierServer> server_;
  std::unique_ptr<hapticd::drivers::Device> device_;
};

std::string name(const ::testing::TestParamInfo<mb::Transport>& info) {
  return info.param == mb::Transport::tcp ? "Tcp" : "Rtu";
}

}  // namespace

TEST_P(DeviceTest, LifecycleEnablesTheAmplifierAndDisableZeroesIt) {
  hapticd::drivers::Device& d = configure();
  EXPECT_TRUE(amplifier_->state().watchdog_armed);  // armed at configure
  Reading r;
  EXPECT_EQ(d.read(r), IoResult::ok);        // valid from configure
  EXPECT_EQ(d.write(0.1), IoResult::error);  // refused until enable
  EXPECT_FALSE(amplifier_->state().enabled);
  d.enable();
  EXPECT_TRUE(amplifier_->state().enabled);
  EXPECT_EQ(d.write(0.5), IoResult::ok);
  EXPECT_EQ(amplifier_->state().applied_torque, 0.0);  // nothing on the wire until the next read()
  EXPECT_EQ(d.read(r), IoResult::ok);
  EXPECT_DOUBLE_EQ(amplifier_->state().applied_torque, 0.5);
  d.disable();
  EXPECT_FALSE(amplifier_->state().enabled);
  EXPECT_EQ(amplifier_->state().torque_counts, 0);
  EXPECT_EQ(amplifier_->state().applied_torque, 0.0);
  d.close();
  EXPECT_FALSE(amplifier_->state().watchdog_armed);  // a clean exit disarms it
  d.close();                                         // idempotent
  EXPECT_EQ(d.read(r), IoResult::error);
}

TEST_P(DeviceTest, OutOfOrderCallsAreLogicErrors) {
  start_amplifier(amplifier_settings(amplifier_config_));
  hapticd::drivers::Device d("modbus", std::make_unique<mb::ModbusDevice>(device_config()));
  EXPECT_THROW(d.enable(), std::logic_error);
  d.configure(LoopContext{test_period_s});
  EXPECT_THROW(d.configure(LoopContext{test_period_s}), std::logic_error);
}

// The model the stability gate gets says delay 1: the run must be the
// loopback run of the same plant with delay = 1, sample by sample.
TEST_P(DeviceTest, ARunEqualsTheLoopbackRunWithOnePeriodOfDelay) {
  hapticd::drivers::Device& d = enabled();
  EXPECT_EQ(d.model().delay_periods, 1);
  // The loopback device's plant with one period of output delay.
  hapticd::drivers::simulation::PlantConfig lc;
  lc.delay = 1;
  hapticd::drivers::simulation::PlantSimulator loop(lc);
  // A spring to a moving set point, rounded to the 1 mN m command count so
  // both see the same torque.
  auto command = [](int n, double x) {
    const double f = 0.3 * std::sin(0.02 * n) - 2.0 * x;
    return std::round(f / 0.001) * 0.001;
  };
  double worst = 0.0;
  for (int n = 0; n < 400; ++n) {
    Reading a, b;
    ASSERT_EQ(d.read(a), IoResult::ok) << n;
    ASSERT_EQ(loop.sense(b.position), IoResult::ok);
    worst = std::max(worst, std::abs(a.position - b.position));
    ASSERT_EQ(d.write(command(n, a.position)), IoResult::ok);
    loop.step(command(n, b.position));
  }
  Reading last;
  loop.sense(last.position);
  EXPECT_GT(std::abs(last.position), 0.05);  // it moved
  EXPECT_LT(worst, 1e-12);
}

TEST_P(DeviceTest, AnExceptionLatchesAFaultWithItsCodeAndClears) {
  hapticd::drivers::Device& d = enabled();
  Reading r;
  ASSERT_EQ(d.write(0.2), IoResult::ok);
  ASSERT_EQ(d.read(r), IoResult::ok);
  server_->inject(mb::sim::Injection::exception, 1, mb::exception_code::server_device_failure);
  EXPECT_EQ(d.read(r), IoResult::fault);
  EXPECT_EQ(d.write(0.2), IoResult::fault);
  EXPECT_EQ(d.status().state, hapticd::drivers::DeviceState::fault);
  EXPECT_EQ(d.status().fault_reason, "exception 0x04 (server device failure) in reply to function 0x17");
  EXPECT_EQ(d.read(r), IoResult::fault);            // latched, though the amplifier answers again ...
  EXPECT_EQ(amplifier_->state().torque_counts, 0);  // ... with torque 0
  const std::string cleared = d.clear_fault();
  EXPECT_EQ(cleared, "exception 0x04 (server device failure) in reply to function 0x17");
  EXPECT_EQ(d.read(r), IoResult::ok);
  EXPECT_EQ(d.write(0.2), IoResult::ok);
  EXPECT_EQ(d.read(r), IoResult::ok);
  EXPECT_DOUBLE_EQ(amplifier_->state().applied_torque, 0.2);
}

TEST_P(DeviceTest, BusyIsTransientButAStreakOfTimeoutsLatches) {
  hapticd::drivers::Device& d = enabled({{"response_timeout", 20e-3}});
  Reading r;
  server_->inject(mb::sim::Injection::exception, 1, mb::exception_code::server_device_busy);
  EXPECT_EQ(d.read(r), IoResult::error);
  EXPECT_EQ(d.read(r), IoResult::ok);
  server_->inject(mb::sim::Injection::timeout, 3);
  EXPECT_EQ(d.read(r), IoResult::error);
  EXPECT_EQ(d.read(r), IoResult::error);
  EXPECT_EQ(d.read(r), IoResult::fault);  // failure_streak = 3
  EXPECT_EQ(
      d.status().fault_reason,
      "3 failed transactions in a row, the last: no response within the response timeout to function 0x17");
  EXPECT_FALSE(d.clear_fault().empty());
  EXPECT_EQ(d.read(r), IoResult::ok);
}

TEST_P(DeviceTest, AnAmplifierFaultIsReportedInItsOwnWordsAndResetOnTheAmplifier) {
  hapticd::drivers::Device& d = enabled();
  Reading r;
  amplifier_->inject_fault(0x0001);
  EXPECT_EQ(d.read(r), IoResult::fault);
  EXPECT_EQ(d.status().fault_reason, "amplifier fault: over-current (fault register 0x0001), status 0x0002");
  EXPECT_FALSE(amplifier_->state().enabled);
  const std::string cleared = d.clear_fault();
  EXPECT_NE(cleared.find("amplifier reset from over-current"), std::string::npos) << cleared;
  EXPECT_EQ(amplifier_->state().resets, 1u);
  EXPECT_TRUE(amplifier_->state().enabled);
  EXPECT_EQ(d.read(r), IoResult::ok);
}

TEST_P(DeviceTest, TheWatchdogDisablesTheAmplifierWhenThePeriodsStop) {
  hapticd::drivers::Device& d = enabled({{"watchdog_value", 50.0}});
  Reading r;
  ASSERT_EQ(d.write(0.3), IoResult::ok);
  ASSERT_EQ(d.read(r), IoResult::ok);
  // hapticd "died": no more periods. The watchdog (50 ms) must trip; were
  // anything still feeding it (the keep-alive), it never would.
  ASSERT_TRUE(eventually([&] { return amplifier_->state().watchdog_trips > 0; }))
      << "the watchdog never tripped";
  EXPECT_FALSE(amplifier_->state().enabled);
  EXPECT_EQ(amplifier_->state().applied_torque, 0.0);
  EXPECT_EQ(amplifier_->state().watchdog_trips, 1u);
  EXPECT_EQ(d.read(r), IoResult::fault);
  EXPECT_EQ(d.status().fault_reason, "amplifier fault: watchdog (fault register 0x0004), status 0x0002");
  EXPECT_FALSE(d.clear_fault().empty());
  EXPECT_TRUE(amplifier_->state().enabled);
  EXPECT_TRUE(amplifier_->state().watchdog_armed);  // every period's write re-arms it
}

TEST_P(DeviceTest, ASilentAmplifierLatchesAfterTheStreak) {
  hapticd::drivers::Device& d = enabled({{"response_timeout", 20e-3}});
  Reading r;
  server_->stop();  // the amplifier answers nothing any more
  EXPECT_EQ(d.read(r), IoResult::error);
  EXPECT_EQ(d.read(r), IoResult::error);
  EXPECT_EQ(d.read(r), IoResult::fault);
  EXPECT_NE(d.status().fault_reason.find("no response"), std::string::npos);
  EXPECT_THROW(d.clear_fault(), DeviceError);  // still silent
  server_->start();
  EXPECT_FALSE(d.clear_fault().empty());
  EXPECT_EQ(d.read(r), IoResult::ok);
}

TEST_P(DeviceTest, ReadAndWriteAllocateNothing) {
  hapticd::drivers::Device& d = enabled();
  ASSERT_TRUE(hapticd::testing::allocation_counting_active());
#ifdef HAPTICD_SANITIZED
  GTEST_SKIP() << "C allocations are counted in the normal build (a sanitizer owns malloc here)";
#endif
  ASSERT_TRUE(mb::testing::c_allocation_counting_active());
  server_->inject(mb::sim::Injection::exception, 2, mb::exception_code::server_device_busy);
  std::size_t cpp = 0, c = 0;
  int reads_ok = 0, writes_ok = 0;
  {
    hapticd::testing::AllocationGuard cpp_guard;
    mb::testing::CAllocationGuard c_guard;
    Reading r;
    for (int i = 0; i < 1000; ++i) {
      reads_ok += d.read(r) == IoResult::ok;
      writes_ok += d.write(0.001 * (i % 7)) == IoResult::ok;
    }
    cpp = cpp_guard.count();
    c = c_guard.count();
  }
  EXPECT_EQ(cpp, 0u);
  EXPECT_EQ(c, 0u);
  EXPECT_EQ(reads_ok, 998) << "every read ok but the two busy exceptions (transient errors)";
  EXPECT_EQ(writes_ok, 1000);
}

// The amplifier keeps its own register map and settings; each one a real
// amplifier's owner may choose, against the driver's keys that say the
// same, and one that says otherwise: only the matching pair carries the
// position and the torque (the two ends are written apart: a misreading on
// one side shows here).
TEST_P(DeviceTest, EachAmplifierSettingWorksWithTheDriversMatchingKeys) {
  struct Variant {
    const char* name;
    std::function<void(mb::sim::AmplifierSettings&)> set;
    Values keys;
  };
  const std::vector<Variant> variants{
      {"low word first",
       [](auto& s) { s.word_order = mb::sim::WordOrder32::low_word_first; },
       {{"word_order", std::string("low-first")}}},
      {"state in input registers",
       [](auto& s) { s.state_table = mb::sim::StateTable::input; },
       {{"read_table", std::string("input")}, {"function_23", false}}},
      {"enable by coil 12",
       [](auto& s) { s.enable_by = mb::sim::EnableBy::coil; },
       {{"enable", std::string("coil")}, {"enable_address", 12.0}}},
  };
  auto run = [&](const Variant& v, const Values& keys) {
    device_.reset();
    if (server_) server_->stop();
    server_.reset();
    mb::sim::AmplifierSettings settings = amplifier_settings(amplifier_config_);
    v.set(settings);
    start_amplifier(settings);
    hapticd::drivers::Device& d = enabled(keys);
    Reading r;
    for (int i = 0; i < 100; ++i) {
      (void)d.write(0.5);
      if (d.read(r) != IoResult::ok) break;
    }
    // The amplifier's thread may still be stepping the plant for the last
    // write: stopped (joined) before the plant is read.
    server_->stop();
    double plant = 0.0;
    plant_.sense(plant);
    return std::pair{std::abs(r.position - plant), amplifier_->state().applied_torque};
  };
  for (const Variant& v : variants) {
    SCOPED_TRACE(v.name);
    const auto [error, torque] = run(v, v.keys);
    EXPECT_LT(error, 1e-9) << "the driver's position is not the plant's";
    EXPECT_DOUBLE_EQ(torque, 0.5);
  }
  // The first variant against the driver's default (high-first) keys: the
  // position words swapped, the reading far from the plant.
  const auto [error, torque] = run(variants[0], {});
  EXPECT_GT(error, 1.0);
  (void)torque;
}

INSTANTIATE_TEST_SUITE_P(ModbusDevice, DeviceTest, ::testing::Values(mb::Transport::tcp, mb::Transport::rtu),
                         name);

class TcpDeviceTest : public DeviceTest {};
TEST_P(TcpDeviceTest, ADroppedConnectionLatchesAndFaultClearReconnects) {
  hapticd::drivers::Device& d = enabled();
  Reading r;
  server_->inject(mb::sim::Injection::drop);
  EXPECT_EQ(d.read(r), IoResult::fault);
  EXPECT_EQ(d.status().fault_reason, "connection closed (Connection reset by peer)");
  const auto requests = d.status().counters[0].value;
  EXPECT_EQ(d.read(r), IoResult::fault);  // no I/O on a closed link
  EXPECT_EQ(d.status().counters[0].value, requests);
  const std::string cleared = d.clear_fault();
  EXPECT_NE(cleared.find("reconnected to tcp 127.0.0.1:"), std::string::npos) << cleared;
  EXPECT_EQ(d.read(r), IoResult::ok);
  EXPECT_EQ(server_->connections(), 2u);
}
TEST_P(TcpDeviceTest, TheMeasuredRoundTripIsInTheBudget) {
  hapticd::drivers::Device& d = configure();
  const mb::LinkBudget b = d.hooks_as<mb::ModbusDevice>().budget();
  EXPECT_EQ(b.rtt_samples, 20);
  EXPECT_GT(b.rtt_p50_s, 0.0);
  EXPECT_LE(b.rtt_p50_s, b.rtt_p99_s);
  EXPECT_LE(b.rtt_p99_s, b.rtt_max_s);
  EXPECT_NE(b.summary.find("fc 23 round trip to 127.0.0.1:"), std::string::npos) << b.summary;
}
TEST_P(TcpDeviceTest, ALinkSlowerThanTheResponseTimeoutIsRefusedWithTheFigure) {
  start_amplifier(amplifier_settings(amplifier_config_));
  server_->inject(mb::sim::Injection::late, 1000, 0, 3);  // every reply 3 ms late
  hapticd::drivers::Device d("modbus",
                             std::make_unique<mb::ModbusDevice>(device_config({{"response_timeout", 1e-3}})));
  try {
    d.configure(LoopContext{test_period_s});
    FAIL() << "a 3 ms round trip passed a 1 ms response timeout";
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.key(), "response_timeout");
    EXPECT_NE(text(e).find("round trip to 127.0.0.1"), std::string::npos) << e.what();
    EXPECT_NE(text(e).find("exceeds the response timeout 1 ms"), std::string::npos) << e.what();
  }
}
// The round trip is measured with the watchdog off and the watchdog armed
// only when everything else passed: a refused start leaves no armed
// watchdog behind to trip 50 ms later and refuse the next start (with the
// amplifier "in fault: watchdog").
// The amplifier's watchdog runs on a clock the test advances: a wait for
// the amplifier to have seen the time, not a sleep.
TEST_P(TcpDeviceTest, ARefusedStartLeavesTheWatchdogDisarmed) {
  start_amplifier(amplifier_settings(amplifier_config_), {}, true);
  // The amplifier has looked at its clock since the test advanced it.
  const auto amplifier_saw = [&](double t) {
    return eventually([&] { return amplifier_->state().time_s >= t; });
  };
  server_->inject(mb::sim::Injection::late, 30, 0, 3);  // the measurement's replies 3 ms late
  {
    hapticd::drivers::Device d("modbus", std::make_unique<mb::ModbusDevice>(device_config(
                                             {{"response_timeout", 1e-3}, {"watchdog_value", 30.0}})));
    EXPECT_THROW(d.configure(LoopContext{test_period_s}), DeviceError);
  }
  EXPECT_FALSE(amplifier_->state().watchdog_armed);
  clock_.advance(0.1);  // 30 ms watchdog: it would have tripped
  ASSERT_TRUE(amplifier_saw(clock_.now_s()));
  EXPECT_EQ(amplifier_->state().watchdog_trips, 0u);
  EXPECT_EQ(amplifier_->state().fault, 0);
  hapticd::drivers::Device next(
      "modbus", std::make_unique<mb::ModbusDevice>(device_config({{"watchdog_value", 30.0}})));
  next.configure(LoopContext{test_period_s});
  EXPECT_TRUE(amplifier_->state().watchdog_armed);  // armed at the end of configure, fed by the keep-alive
  // 100 ms of the amplifier's time in 10 ms steps, each one fed: a refresh
  // at or after the new time (a keep-alive that stopped never gives one).
  for (int step = 0; step < 10; ++step) {
    clock_.advance(0.01);
    ASSERT_TRUE(eventually([&] { return amplifier_->state().refreshed_s >= clock_.now_s(); }))
        << "the keep-alive did not feed the watchdog after " << 10 * (step + 1) << " ms";
  }
  EXPECT_EQ(amplifier_->state().watchdog_trips, 0u);
  next.close();
  EXPECT_FALSE(amplifier_->state().watchdog_armed);  // a clean stop disarms it
}
INSTANTIATE_TEST_SUITE_P(ModbusDevice, TcpDeviceTest, ::testing::Values(mb::Transport::tcp), name);

class RtuDeviceTest : public DeviceTest {};
TEST_P(RtuDeviceTest, AWrongSlaveIdTimesOutNamingTheKey) {
  start_amplifier(amplifier_settings(amplifier_config_));
  hapticd::drivers::Device d("modbus", std::make_unique<mb::ModbusDevice>(
                                           device_config({{"slave_id", 7.0}, {"response_timeout", 20e-3}})));
  try {
    d.configure(LoopContext{test_period_s});
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.key(), "slave_id");
    EXPECT_NE(text(e).find("check slave_id, the wiring, baud rate and parity"), std::string::npos)
        << e.what();
  }
}
INSTANTIATE_TEST_SUITE_P(ModbusDevice, RtuDeviceTest, ::testing::Values(mb::Transport::rtu), name);

TEST_P(DeviceTest, AnAmplifierWithoutFunction23IsRefusedUnlessConfiguredSo) {
  auto settings = amplifier_settings(amplifier_config_);
  settings.function_23 = false;
  start_amplifier(settings);
  try {
    hapticd::drivers::Device d("modbus", std::make_unique<mb::ModbusDevice>(device_config()));
    d.configure(LoopContext{test_period_s});
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.key(), "function_23");
    EXPECT_NE(text(e).find("set function_23 = false"), std::string::npos) << e.what();
  }
  hapticd::drivers::Device d("modbus",
                             std::make_unique<mb::ModbusDevice>(device_config({{"function_23", false}})));
  d.configure(LoopContext{test_period_s});
  d.enable();
  const auto before = d.status().counters[0].value;
  Reading r;
  ASSERT_EQ(d.write(0.1), IoResult::ok);
  ASSERT_EQ(d.read(r), IoResult::ok);
  EXPECT_EQ(d.status().counters[0].value - before, 2u);  // fc 16 + fc 3: two requests a period
  EXPECT_DOUBLE_EQ(amplifier_->state().applied_torque, 0.1);
}

TEST_P(DeviceTest, AnAmplifierInFaultAtStartIsRefusedUnlessResetOnStart) {
  start_amplifier(amplifier_settings(amplifier_config_), [this] {
    amplifier_->inject_fault(0x0004);
    amplifier_->tick(0.0);  // before the server thread: TSan found it racing that thread's tick()
  });
  try {
    hapticd::drivers::Device d("modbus", std::make_unique<mb::ModbusDevice>(device_config()));
    d.configure(LoopContext{test_period_s});
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.key(), "reset_on_start");
    EXPECT_NE(text(e).find("is in fault: watchdog (fault register 0x0004)"), std::string::npos) << e.what();
  }
  hapticd::drivers::Device d("modbus",
                             std::make_unique<mb::ModbusDevice>(device_config({{"reset_on_start", true}})));
  d.configure(LoopContext{test_period_s});
  EXPECT_EQ(amplifier_->state().fault, 0);
}

TEST(ModbusDeviceBudget, AnRtuLinkTooSlowForThePeriodIsRefusedWithTheFigure) {
  hapticd::drivers::Device d("modbus",
                             std::make_unique<mb::ModbusDevice>(mb::modbus_config(
                                 {{"transport", std::string("rtu")}, {"device", std::string("/dev/null")}})));
  try {
    d.configure(LoopContext{1e-3});
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.key(), "baud");
    // Default map at 115200 8E1, spec silences: 6.75 ms (rtu_timing_test works it out).
    EXPECT_EQ(
        text(e),
        "modbus: one exchange (fc 23, 34 bytes of 11-bit characters at 115200 baud, 2 x 1.75 ms silence, "
        "0 us turnaround) takes 6.75 ms; link_budget 0.50 x period 1 ms = 500 us; it needs a period of at "
        "least 13.5 ms, or TCP: no baud rate carries it with the spec's 1.75 ms silences above 19200 baud "
        "(silence = \"characters\" if the amplifier keeps 3.5 characters)");
  }
  hapticd::drivers::Device fast("modbus", std::make_unique<mb::ModbusDevice>(
                                              mb::modbus_config({{"transport", std::string("rtu")},
                                                                 {"device", std::string("/dev/null")},
                                                                 {"silence", std::string("characters")}})));
  try {
    fast.configure(LoopContext{1e-3});
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_NE(text(e).find("or 921600 baud, or TCP"), std::string::npos) << e.what();
  }
}

TEST(ModbusDeviceBudget, AResponseTimeoutBeyondTheBudgetIsRefused) {
  hapticd::drivers::Device d(
      "modbus", std::make_unique<mb::ModbusDevice>(mb::modbus_config({{"response_timeout", 0.8e-3}})));
  try {
    d.configure(LoopContext{1e-3});
    FAIL();
  } catch (const DeviceError& e) {
    EXPECT_EQ(e.key(), "response_timeout");
    EXPECT_NE(text(e).find("accepted: up to 500 us"), std::string::npos) << e.what();
  }
}

TEST_P(RtuDeviceTest, ACrcErrorIsATransientReadError) {
  hapticd::drivers::Device& d = enabled();
  Reading r;
  server_->inject(mb::sim::Injection::crc_error);
  EXPECT_EQ(d.read(r), IoResult::error);
  EXPECT_EQ(d.read(r), IoResult::ok);
  server_->inject(mb::sim::Injection::crc_error, 3);
  EXPECT_EQ(d.read(r), IoResult::error);
  EXPECT_EQ(d.read(r), IoResult::error);
  EXPECT_EQ(d.read(r), IoResult::fault);
  EXPECT_EQ(d.status().fault_reason,
            "3 failed transactions in a row, the last: CRC error in reply to function 0x17");
}

// ---- issue 17 item 8: an amplifier whose watchdog wants an alive counter ----

namespace {

mb::sim::AmplifierSettings alive_counter_amplifier(const mb::ModbusConfig& c) {
  mb::sim::AmplifierSettings s = amplifier_settings(c);
  s.alive_counter_s = 5.0;  // and an unchanged value trips at once
  return s;
}

/// Periods of torque `force` until one is not ok; how many were ok.
int periods_ok(hapticd::drivers::Device& d, int periods, double force, IoResult& last) {
  Reading r;
  for (int i = 0; i < periods; ++i) {
    (void)d.write(force);
    last = d.read(r);
    if (last != IoResult::ok) return i;
  }
  return periods;
}

}  // namespace

// What the issue found: watchdog_refresh = "write" rewrites watchdog_value,
// the same value every period, and such an amplifier trips while hapticd runs.
TEST_P(DeviceTest, AnAliveCounterAmplifierTripsOnTheRewrittenWatchdogValue) {
  start_amplifier(alive_counter_amplifier(amplifier_config_));
  hapticd::drivers::Device& d = enabled();
  IoResult last = IoResult::ok;
  EXPECT_LT(periods_ok(d, 20, 0.1, last), 20);
  EXPECT_EQ(last, IoResult::fault);
  EXPECT_EQ(amplifier_->state().watchdog_trips, 1u);
  EXPECT_FALSE(amplifier_->state().enabled);
  EXPECT_EQ(d.status().fault_reason, "amplifier fault: watchdog (fault register 0x0004), status 0x0002");
}

TEST_P(DeviceTest, WatchdogRefreshCounterKeepsAnAliveCounterAmplifierEnabled) {
  start_amplifier(alive_counter_amplifier(amplifier_config_));
  hapticd::drivers::Device& d = enabled({{"watchdog_refresh", std::string("counter")}});
  IoResult last = IoResult::ok;
  EXPECT_EQ(periods_ok(d, 50, 0.1, last), 50) << d.status().fault_reason;
  const mb::sim::AmplifierState s = amplifier_->state();
  EXPECT_EQ(s.watchdog_trips, 0u);
  EXPECT_TRUE(s.enabled);
  EXPECT_DOUBLE_EQ(s.applied_torque, 0.1);
  EXPECT_EQ(s.alive_jumps, 0u) << "the counter moved by other than one";
  d.disable();  // the counter is watched while the power stage is on
  d.close();
  EXPECT_EQ(amplifier_->state().watchdog_trips, 0u);
}

TEST_P(DeviceTest, TheAliveCounterWrapsFrom0xFFFFTo0) {
  start_amplifier(alive_counter_amplifier(amplifier_config_));
  // watchdog_value is the counter's first value: 65530, ... 65535, 0, 1 ...
  hapticd::drivers::Device& d =
      enabled({{"watchdog_refresh", std::string("counter")}, {"watchdog_value", 65530.0}});
  IoResult last = IoResult::ok;
  EXPECT_EQ(periods_ok(d, 20, 0.1, last), 20) << d.status().fault_reason;
  const mb::sim::AmplifierState s = amplifier_->state();
  EXPECT_LT(s.watchdog_register, 65530) << "not wrapped";
  EXPECT_EQ(s.alive_jumps, 0u) << "0xFFFF -> 0 is one step";
  EXPECT_EQ(s.watchdog_trips, 0u);
}

// ---- issue 17 item 9: the lifecycle's waits give way to the daemon's stop ----

// configure(), enable() and clear_fault() wait up to connect_timeout (10 s
// here) for each exchange; a stop ends the wait after one slice.
TEST_P(DeviceTest, EnableGivesWayToAStopOnASilentAmplifier) {
  hapticd::drivers::Device& d = configure({{"connect_timeout", 10.0}});
  server_->inject(mb::sim::Injection::timeout, 1000000);
  stop_.request("the test");
  EXPECT_THROW(d.enable(), StopRequested);
  EXPECT_FALSE(amplifier_->state().enabled);
  d.close();
}

TEST_P(DeviceTest, FaultClearGivesWayToAStopOnASilentAmplifier) {
  hapticd::drivers::Device& d = enabled({{"connect_timeout", 10.0}});
  server_->inject(mb::sim::Injection::timeout, 1000000);
  IoResult last = IoResult::ok;
  Reading r;
  for (int i = 0; i < 10 && last != IoResult::fault; ++i) last = d.read(r);
  ASSERT_EQ(last, IoResult::fault);
  stop_.request("the test");
  try {
    d.clear_fault();
    FAIL() << "cleared";
  } catch (const StopRequested& e) {
    EXPECT_NE(std::string(e.what()).find("clearing the fault: abandoned, hapticd is stopping"),
              std::string::npos)
        << e.what();
  }
  EXPECT_EQ(d.status().state, DeviceState::fault);
  d.close();
}

// The amplifier of the issue: it accepts the connection and never answers.
// The stop comes while configure() waits for its first reply.
TEST(ModbusDeviceStop, ConfigureGivesWayToAStopOnAServerThatNeverAnswers) {
  mb::testing::HostileServer server;
  server.silent = true;
  StopRequest stop;
  hapticd::drivers::Device d(
      "modbus",
      std::make_unique<mb::ModbusDevice>(mb::modbus_config(
          {{"port", static_cast<double>(server.port())}, {"connect_timeout", 10.0}, {"link_budget", 0.9}})));
  std::thread stopper([&] {
    EXPECT_TRUE(eventually([&] { return server.requests.load() >= 1; }));
    stop.request("the test");
  });
  try {
    d.configure(LoopContext{test_period_s, stop.token()});
    FAIL() << "configured";
  } catch (const StopRequested& e) {
    EXPECT_EQ(std::string(e.what()),
              "modbus: tcp 127.0.0.1:" + std::to_string(server.port()) +
                  " unit 1: reading the amplifier's state: abandoned, hapticd is stopping");
  } catch (const DeviceError& e) {
    ADD_FAILURE() << "waited the whole connect_timeout: " << e.what();
  }
  stopper.join();
  EXPECT_EQ(d.status().state, DeviceState::closed);
}

// ---- issue 17 item 7: replies from another unit id ----

// The driver took a reply with its transaction id but unit id 7 as unit
// 1's, period after period. Now each such exchange fails (a malformed reply,
// naming the unit), the streak latches, and the device status counts them.
TEST(ModbusDeviceHostile, RepliesFromAnotherUnitAreRefusedCountedAndLatch) {
  mb::testing::HostileServer server;
  hapticd::drivers::Device d("modbus", std::make_unique<mb::ModbusDevice>(
                                           mb::modbus_config({{"port", static_cast<double>(server.port())},
                                                              {"link_budget", 0.9},
                                                              {"rtt_samples", 20.0},
                                                              {"failure_streak", 3.0},
                                                              {"watchdog_value", 1000.0}})));
  d.configure(LoopContext{test_period_s});
  d.enable();
  Reading r;
  ASSERT_EQ(d.read(r), IoResult::ok);
  server.reply_unit = 7;
  EXPECT_EQ(d.read(r), IoResult::error);
  EXPECT_EQ(d.read(r), IoResult::error);
  EXPECT_EQ(d.read(r), IoResult::fault);
  const hapticd::drivers::DeviceStatus s = d.status();
  EXPECT_EQ(
      s.fault_reason,
      "3 failed transactions in a row, the last: malformed reply in reply to function 0x17 (from unit 7, "
      "not the unit 1 it was sent to)");
  std::uint64_t wrong_unit = 0;
  for (const auto& c : s.counters)
    if (c.name == "wrong_unit_replies") wrong_unit = c.value;
  EXPECT_GE(wrong_unit, 3u);
  server.reply_unit = -1;
  EXPECT_FALSE(d.clear_fault().empty());
  EXPECT_EQ(d.read(r), IoResult::ok);
}

}  // namespace device_test
