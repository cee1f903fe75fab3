// CiA 402 homing through the driver's hooks (CanopenDevice::enable with
// homing = "cia402") against the simulated drive's bus loop in a thread, on
// the unix seam, in real time: the drive homes in mode 6 and comes back in
// cyclic synchronous torque; every refusal is a DeviceError naming its
// config key; a stop cuts the homing short.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <numbers>
#include <string>
#include <thread>

#include "drivers/canopen/canopen_device.hpp"
#include "drivers/stop_request.hpp"
#include "sim/canopen/drive_bus.hpp"
#include "sim/canopen/simulated_drive.hpp"

namespace homing_device_test {

namespace canopen = hapticd::drivers::canopen;
namespace sim = hapticd::drivers::canopen::sim;
namespace drivers = hapticd::drivers;
using drivers::IoResult;
using drivers::Reading;
using namespace std::chrono_literals;

namespace {

constexpr double period_s = 1e-3;
constexpr double counts_per_rad = 16384.0 / (2.0 * std::numbers::pi);

class Wheel final : public sim::DrivePlant {
 public:
  double position() const override { return x; }
  double velocity() const override { return v; }
  void step(double force) override {
    const double a = (force - 0.002 * v) / 0.01;  // J = 0.01 kg m^2
    x += v * period_s + 0.5 * a * period_s * period_s;
    v += a * period_s;
  }
  std::atomic<double> x = 0.0, v = 0.0;
};

std::string unique_path() {
  static std::atomic<int> n{0};
  return (std::filesystem::temp_directory_path() /
          ("hapticd-canopen-homing-" + std::to_string(::getpid()) + "-" + std::to_string(n++)))
      .string();
}

class HomingDevice : public ::testing::Test {
 protected:
  void start_drive(bool offers_homing = true, double start_at = 0.0) {
    plant.x = start_at;
    sim::DriveSettings s;
    s.node_id = 5;
    s.rated_torque_mnm = 500;
    if (offers_homing) s.supported_modes |= 1U << 5;
    s.limit_switches = {-0.5, 0.5};
    s.period_s = period_s;
    s.moving_mass = 0.01;
    drive = std::make_unique<sim::SimulatedDrive>(s, plant);
    bus = std::make_unique<sim::DriveBus>(path, *drive);
    thread = std::thread([this] { bus->run(stop); });
  }
  /// The RT loop in its own thread (the SDO answers come through it once enabled).
  void start_loop(double force) {
    loop_force = force;
    loop = std::thread([this] {
      auto next = std::chrono::steady_clock::now();
      while (!loop_stop) {
        Reading r;
        if (device->read(r) == IoResult::ok) loop_position = r.position;
        device->write(loop_force.load());
        next += 1ms;
        std::this_thread::sleep_until(next);
      }
    });
  }
  void stop_loop() {
    loop_stop = true;
    if (loop.joinable()) loop.join();
  }
  ~HomingDevice() override {
    stop_loop();
    if (device) {
      device->disable();
      device->close();
    }
    stop = true;
    if (thread.joinable()) thread.join();
  }
  canopen::CanopenConfig homing_config(int method) const {
    canopen::CanopenConfig c;
    c.interface = "unix:" + path;
    c.node_id = 5;
    c.tpdo_timeout_periods = 5000;
    c.heartbeat_timeout = 1.0;
    c.sdo_timeout = 2.0;
    c.homing = true;
    c.homing_method = method;
    c.home_offset = 0.25;
    c.homing_speed_switch = 1.0;
    c.homing_speed_zero = 0.2;
    c.homing_acceleration = 10.0;
    c.homing_timeout = 5.0;
    return c;
  }
  /// configure + enable; the DeviceError's key when it is refused ("" when it is not).
  std::string enable(const canopen::CanopenConfig& c, const drivers::StopToken& token = {}) {
    device = std::make_unique<canopen::CanopenDevice>(c);
    device->configure({period_s, token});
    try {
      device->enable();
    } catch (const drivers::DeviceError& e) {
      error = e.what();
      return e.key();
    }
    return "";
  }
  /// The position read through the hooks, after a few periods of zero torque.
  double position_now() {
    Reading r;
    for (int i = 0; i < 5; ++i) {
      (void)device->read(r);
      (void)device->write(0.0);
      std::this_thread::sleep_for(1ms);
    }
    return r.position;
  }

  std::string path = unique_path();
  Wheel plant;
  std::unique_ptr<sim::SimulatedDrive> drive;
  std::unique_ptr<sim::DriveBus> bus;
  std::atomic<bool> stop{false};
  std::thread thread;
  std::unique_ptr<canopen::CanopenDevice> device;
  std::string error;
  std::thread loop;
  std::atomic<bool> loop_stop{false};
  std::atomic<double> loop_force{0.0};
  std::atomic<double> loop_position{0.0};
};

TEST_F(HomingDevice, OnTheCurrentPositionThenBackInCyclicSynchronousTorque) {
  start_drive(true, 1.2);  // an incremental encoder: 1.2 rad from where it powered up
  ASSERT_EQ(enable(homing_config(37)), "") << error;
  const auto homing = device->homing();
  ASSERT_TRUE(homing.has_value());
  EXPECT_EQ(homing->method, 37);
  EXPECT_EQ(homing->description, "CiA 402 homing method 37 (on the current position)");
  EXPECT_GE(homing->periods, canopen::tpdos_after_start);
  EXPECT_LT(homing->periods, 50u) << "no motion: done at the first SYNC after the start";
  // CiA 402: the home (here, where it stood) reads -home_offset.
  EXPECT_NEAR(homing->home_position, -0.25, 1.0 / counts_per_rad);
  EXPECT_NEAR(position_now(), -0.25, 1.0 / counts_per_rad);
  start_loop(0.0);
  EXPECT_EQ(device->sdo_read({0x6061, 0}, std::nullopt).value, 10) << "the loop's mode again";
  EXPECT_EQ(device->sdo_read({0x6098, 0}, std::nullopt).raw, 37u);
  EXPECT_EQ(device->sdo_read({0x607C, 0}, std::nullopt).raw,
            static_cast<std::uint32_t>(std::lround(0.25 * counts_per_rad)));
  // Torque flows in mode 10 as before.
  loop_force = 0.2;
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (std::abs(bus->applied_force() - 0.2) > 0.001 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(1ms);
  EXPECT_NEAR(bus->applied_force(), 0.2, 0.001);
  stop_loop();
  EXPECT_NE(device->identity().find("node 5"), std::string::npos);
  EXPECT_NE(device->identity().find("serial 0x00000001"), std::string::npos) << device->identity();
}

TEST_F(HomingDevice, OnTheNegativeLimitSwitchTheDriveMovesToItsEdge) {
  start_drive();
  ASSERT_EQ(enable(homing_config(17)), "") << error;
  const auto homing = device->homing();
  ASSERT_TRUE(homing.has_value());
  EXPECT_EQ(homing->description, "CiA 402 homing method 17 (on the negative limit switch)");
  // 0.5 rad at 1 rad/s, back off the switch at 0.2 rad/s, stop: about a second.
  EXPECT_GT(homing->periods, 500u);
  EXPECT_LT(homing->periods, 3000u);
  EXPECT_NEAR(homing->duration_s, static_cast<double>(homing->periods) * period_s, 1e-12);
  // The plant stands just off the switch; the home (its edge) reads -home_offset.
  EXPECT_GT(plant.x.load(), -0.5);
  EXPECT_NEAR(plant.x.load(), -0.5, 0.05);
  const double home_reading = -0.25 + (plant.x.load() - (-0.5));
  EXPECT_NEAR(position_now(), home_reading, 0.002) << "measured from the edge";
  std::cout << "homing on the negative limit switch: " << homing->periods << " periods\n";
}

TEST_F(HomingDevice, EveryRefusalNamesItsKey) {
  start_drive();
  EXPECT_EQ(enable(homing_config(1)), "homing_method") << "no index pulse on this drive";
  EXPECT_NE(error.find("0x6098"), std::string::npos) << error;
  EXPECT_NE(error.find("aborted 0x06090030"), std::string::npos) << error;
  device.reset();

  auto slow = homing_config(17);
  slow.homing_timeout = 0.05;  // the switch is 0.5 s away
  EXPECT_EQ(enable(slow), "homing_timeout") << error;
  EXPECT_NE(error.find("did not complete after"), std::string::npos) << error;
  EXPECT_NE(error.find("homing in progress"), std::string::npos) << error;
}

TEST_F(HomingDevice, TheOtherSidesSwitchIsAHomingErrorFromTheDrive) {
  start_drive(true, 0.6);  // beyond the positive switch
  EXPECT_EQ(enable(homing_config(17)), "homing_method") << error;
  EXPECT_NE(error.find("the drive reports a homing error"), std::string::npos) << error;
  EXPECT_NE(error.find("homing error, velocity 0"), std::string::npos) << error;
}

TEST_F(HomingDevice, ADriveWithoutHomingModeIsRefusedNamingHoming) {
  start_drive(false);
  EXPECT_EQ(enable(homing_config(37)), "homing") << error;
  EXPECT_NE(error.find("does not offer homing mode: 0x6502"), std::string::npos) << error;
}

TEST_F(HomingDevice, AStopCutsTheHomingShortWithinASlice) {
  start_drive();
  drivers::StopRequest request;
  device = std::make_unique<canopen::CanopenDevice>(homing_config(17));
  device->configure({period_s, request.token()});
  std::thread stopper([&] {
    std::this_thread::sleep_for(200ms);  // moving towards the switch by then
    request.request("SIGTERM");
  });
  const auto before = std::chrono::steady_clock::now();
  EXPECT_THROW(device->enable(), drivers::StopRequested);
  const auto took = std::chrono::steady_clock::now() - before;
  stopper.join();
  EXPECT_LT(took, 200ms + drivers::stop_slice + 200ms);
  EXPECT_FALSE(device->homing().has_value());
}

}  // namespace

}  // namespace homing_device_test
