// The canopen hooks' blocking waits give way to the daemon's stop (issue 17,
// item 9): an SDO transfer in configure, the CiA 402 state waits of enable
// and of a fault clear. Each wait would last its timeout (seconds); a stop
// ends it after one slice with StopRequested. The hooks run inside the
// framework's Device, as the daemon runs them. No timing is asserted: a
// wait that did not give way ends in a SetupError instead, and the test
// fails by that.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <memory>
#include <thread>

#include "drivers/canopen/301/cob_id.hpp"
#include "drivers/canopen/can_socket.hpp"
#include "drivers/canopen/canopen_device.hpp"
#include "drivers/device.hpp"
#include "drivers/stop_request.hpp"
#include "sim/canopen/drive_bus.hpp"
#include "sim/canopen/simulated_drive.hpp"

namespace stop_test {

namespace canopen = hapticd::drivers::canopen;
namespace sim = hapticd::drivers::canopen::sim;
namespace co = hapticd::drivers::canopen::cia301;
using hapticd::drivers::Device;
using hapticd::drivers::DeviceState;
using hapticd::drivers::IoResult;
using hapticd::drivers::Reading;
using hapticd::drivers::StopRequest;
using hapticd::drivers::StopRequested;
using namespace std::chrono_literals;

namespace {

constexpr double period_s = 1e-3;
constexpr std::uint8_t node = 5;

class StillPlant final : public sim::DrivePlant {
 public:
  double position() const override { return 0.0; }
  double velocity() const override { return 0.0; }
  void step(double) override {}
};

std::string unique_path() {
  static std::atomic<int> n{0};
  return (std::filesystem::temp_directory_path() /
          ("hapticd-canopen-stop-" + std::to_string(::getpid()) + "-" + std::to_string(n++)))
      .string();
}

template <class Condition>
bool eventually(Condition&& condition) {
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (!condition() && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(1ms);
  return condition();
}

canopen::CanopenConfig config(const std::string& path) {
  canopen::CanopenConfig c;
  c.interface = "unix:" + path;
  c.node_id = node;
  c.tpdo_timeout_periods = 5000;
  c.heartbeat_period = 0.02;
  c.heartbeat_timeout = 1.0;
  c.sdo_timeout = 10.0;  // each wait below would last this long without the stop
  return c;
}

}  // namespace

// A peer that accepts the connection and never answers an SDO: configure()
// waits in its first transfer. The stop ends it, and the client aborts the
// transfer on the bus (CiA 301: 0x05040000, SDO protocol timed out).
TEST(CanopenStop, ConfigureGivesWayToAStopDuringAnSdoTransfer) {
  const std::string path = unique_path();
  canopen::CanListener listener = canopen::CanListener::listen(path);
  StopRequest stop;
  bool aborted = false;
  std::thread peer([&] {
    canopen::CanSocket s = listener.accept(10s);
    ASSERT_TRUE(s.is_open());
    co::Frame f;
    auto next = [&] {
      while (s.wait_readable(10s))
        if (s.receive(f) == canopen::IoStatus::ok) return true;
      return false;
    };
    while (next() && f.id != co::sdo_request_id(node)) {
    }
    ASSERT_EQ(f.id, co::sdo_request_id(node)) << "no SDO request came";
    stop.request("the test");
    ASSERT_TRUE(next());
    aborted = f.id == co::sdo_request_id(node) && f.data[0] == 0x80 && f.data[4] == 0x00 &&
              f.data[5] == 0x00 && f.data[6] == 0x04 && f.data[7] == 0x05;
  });
  Device device("canopen", std::make_unique<canopen::CanopenDevice>(config(path)));
  try {
    device.configure({period_s, stop.token()});
    ADD_FAILURE() << "configured against a peer that answers nothing";
  } catch (const StopRequested& e) {
    EXPECT_EQ(std::string(e.what()),
              "canopen: SDO read 0x1000:00 from node 5: no answer: abandoned, hapticd is stopping");
  } catch (const canopen::SetupError& e) {
    ADD_FAILURE() << "waited the whole sdo_timeout: " << e.what();
  }
  peer.join();
  EXPECT_TRUE(aborted) << "the transfer was not aborted on the bus";
  EXPECT_EQ(device.status().state, DeviceState::closed);
}

namespace {

/// The simulated drive on its bus thread, and the canopen device on it.
class DriveStop : public ::testing::Test {
 protected:
  DriveStop() : path_(unique_path()), drive_(settings(), plant_), bus_(path_, drive_) {
    thread_ = std::thread([this] { bus_.run(bus_stop_); });
    device_ = std::make_unique<Device>("canopen", std::make_unique<canopen::CanopenDevice>(config(path_)));
    device_->configure({period_s, stop_.token()});
  }
  ~DriveStop() override {
    stop_loop();
    device_.reset();
    bus_stop_ = true;
    thread_.join();
  }
  canopen::ExchangeStatus exchange() const {
    return device_->hooks_as<canopen::CanopenDevice>().exchange_status();
  }
  static sim::DriveSettings settings() {
    sim::DriveSettings s;
    s.node_id = node;
    s.rated_torque_mnm = 500;
    return s;
  }
  void start_loop() {
    loop_ = std::thread([this] {
      auto next = std::chrono::steady_clock::now();
      while (!loop_stop_) {
        Reading r;
        last_read_ = device_->read(r);
        device_->write(0.0);
        next += 1ms;
        std::this_thread::sleep_until(next);
      }
    });
  }
  void stop_loop() {
    loop_stop_ = true;
    if (loop_.joinable()) loop_.join();
  }

  std::string path_;
  StillPlant plant_;
  sim::SimulatedDrive drive_;
  sim::DriveBus bus_;
  std::atomic<bool> bus_stop_{false};
  std::thread thread_;
  StopRequest stop_;
  std::unique_ptr<Device> device_;
  std::thread loop_;
  std::atomic<bool> loop_stop_{false};
  std::atomic<IoResult> last_read_{IoResult::ok};
};

}  // namespace

// enable() runs periods until the drive reports Operation Enabled (1 s at
// most); a drive that stopped answering never does. The stop ends it, with
// the power stage asked off again.
TEST_F(DriveStop, EnableGivesWayToAStop) {
  ASSERT_EQ(bus_.command("mute").rfind("ok", 0), 0U);
  stop_.request("the test");
  try {
    device_->enable();
    FAIL() << "enabled a mute drive";
  } catch (const StopRequested& e) {
    EXPECT_EQ(std::string(e.what()), "canopen: enabling node 5: abandoned, hapticd is stopping");
  } catch (const canopen::SetupError& e) {
    FAIL() << "waited the whole enable timeout: " << e.what();
  }
  EXPECT_NE(device_->status().state, DeviceState::enabled);
}

// clear_fault() hands the fault reset to the running loop and waits for the
// drive (1.5 s at most); one that stopped answering stays in fault.
TEST_F(DriveStop, FaultClearGivesWayToAStop) {
  device_->enable();
  start_loop();
  ASSERT_EQ(bus_.command("fault 0x2310").rfind("ok", 0), 0U);
  ASSERT_TRUE(eventually([&] { return exchange().faulted; }));
  ASSERT_EQ(bus_.command("mute").rfind("ok", 0), 0U);
  stop_.request("the test");
  try {
    device_->clear_fault();
    FAIL() << "cleared on a mute drive";
  } catch (const StopRequested& e) {
    EXPECT_EQ(std::string(e.what()), "canopen: clearing the fault of node 5: abandoned, hapticd is stopping");
  } catch (const canopen::SetupError& e) {
    FAIL() << "waited the whole reset timeout: " << e.what();
  }
  // The loop may be in the reset it was handed (its own timeout faults it
  // again); the engine's latch, not cleared, keeps the output at zero.
  EXPECT_FALSE(exchange().operational);
  stop_loop();
}

}  // namespace stop_test
