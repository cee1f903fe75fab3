// Several drives on one bus (issue 22): the simulated bus (sim/canopen/
// can_bus.hpp) relays every frame a member sends to every other member, not
// the sender; simulated drives join it as members; the driver's hooks for
// several drives (CanopenBusDevice) run one SYNC for all, each node's PDOs,
// heartbeat and EMCY, zero every axis when one node faults, check the bus
// budget of all nodes first, and allocate nothing per period; with homing
// every node homes in the same periods. Real time, in
// one process: the bus, each drive and the loop in their own threads.

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <thread>
#include <vector>

#include "drivers/canopen/301/cob_id.hpp"
#include "drivers/canopen/canopen_bus_device.hpp"
#include "drivers/canopen/canopen_config.hpp"
#include "sim/canopen/can_bus.hpp"
#include "sim/canopen/drive_bus.hpp"
#include "sim/canopen/simulated_drive.hpp"
#include "tests/support/alloc_counter.hpp"

namespace canbus_test {

namespace canopen = hapticd::drivers::canopen;
namespace sim = hapticd::drivers::canopen::sim;
namespace co = hapticd::drivers::canopen::cia301;
using hapticd::drivers::IoResult;
using hapticd::drivers::Reading;
using namespace std::chrono_literals;

namespace {

constexpr double period_s = 1e-3;

std::string unique_path() {
  static std::atomic<int> n{0};
  return (std::filesystem::temp_directory_path() /
          ("hapticd-canbus-" + std::to_string(::getpid()) + "-" + std::to_string(n++)))
      .string();
}

template <class Condition>
bool eventually(Condition&& condition, std::chrono::milliseconds limit = 10000ms) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < deadline) {
    if (condition()) return true;
    std::this_thread::sleep_for(1ms);
  }
  return condition();
}

co::Frame frame(std::uint32_t id, std::uint8_t first_byte) {
  co::Frame f;
  f.id = id;
  f.len = 2;
  f.data[0] = first_byte;
  f.data[1] = 0xA5;
  return f;
}

/// Every frame `member` has queued now (none waits).
std::vector<co::Frame> received(canopen::CanSocket& member) {
  std::vector<co::Frame> out;
  co::Frame f;
  while (member.receive(f) == canopen::IoStatus::ok) out.push_back(f);
  return out;
}

class CanBusTest : public ::testing::Test {
 protected:
  CanBusTest() : path(unique_path()), bus(path) {}
  canopen::CanSocket join() {
    canopen::CanSocket s = canopen::CanSocket::open("unix:" + path, {}, 0);
    const std::size_t before = bus.members();
    EXPECT_TRUE(eventually([&] {
      bus.poll_once(1ms);
      return bus.members() == before + 1;
    }));
    return s;
  }
  /// Turns of the relay until it has received `frames` frames in all.
  void relay_until(std::uint64_t frames) {
    EXPECT_TRUE(eventually([&] {
      bus.poll_once(1ms);
      return bus.frames_relayed() >= frames;
    }));
  }
  std::string path;
  sim::CanBus bus;
};

TEST_F(CanBusTest, AFrameFromOneMemberReachesEveryOtherMemberNotTheSender) {
  canopen::CanSocket a = join(), b = join(), c = join();
  ASSERT_EQ(bus.members(), 3U);
  ASSERT_EQ(a.send(frame(0x080, 0)), canopen::IoStatus::ok);  // a SYNC from hapticd
  ASSERT_EQ(a.send(frame(0x201, 1)), canopen::IoStatus::ok);  // then node 1's RPDO1
  relay_until(2);
  for (canopen::CanSocket* other : {&b, &c}) {
    const auto got = received(*other);
    ASSERT_EQ(got.size(), 2U);
    EXPECT_EQ(got[0].id, 0x080U) << "in the order sent";
    EXPECT_EQ(got[1].id, 0x201U);
    EXPECT_EQ(got[1].len, 2U);
    EXPECT_EQ(got[1].data[1], 0xA5);
  }
  EXPECT_TRUE(received(a).empty()) << "a CAN controller does not hear its own frame";

  ASSERT_EQ(b.send(frame(0x181, 2)), canopen::IoStatus::ok);  // node 1's TPDO1
  relay_until(3);
  const auto at_a = received(a), at_c = received(c);
  ASSERT_EQ(at_a.size(), 1U);
  ASSERT_EQ(at_c.size(), 1U);
  EXPECT_EQ(at_a[0].id, 0x181U);
  EXPECT_EQ(at_c[0].data[0], 2);
  EXPECT_TRUE(received(b).empty());
  EXPECT_EQ(bus.deliveries_dropped(), 0U);
}

TEST_F(CanBusTest, AMemberThatLeavesIsDroppedAndTheOthersStillHearEachOther) {
  canopen::CanSocket a = join(), b = join(), c = join();
  c.close();
  ASSERT_EQ(a.send(frame(0x702, 5)), canopen::IoStatus::ok);
  relay_until(1);
  EXPECT_TRUE(eventually([&] {
    bus.poll_once(1ms);
    return bus.members() == 2U;
  }));
  ASSERT_EQ(received(b).size(), 1U);
  ASSERT_EQ(b.send(frame(0x082, 9)), canopen::IoStatus::ok);
  relay_until(2);
  const auto at_a = received(a);
  ASSERT_EQ(at_a.size(), 1U);
  EXPECT_EQ(at_a[0].id, 0x082U);
}

TEST_F(CanBusTest, AMessageThatIsNoCanFrameDoesNotTravel) {
  canopen::CanSocket a = join(), b = join();
  const char five[5] = {1, 2, 3, 4, 5};
  ASSERT_EQ(::send(a.fd(), five, sizeof five, 0), 5);
  ASSERT_EQ(a.send(frame(0x181, 7)), canopen::IoStatus::ok);
  relay_until(1);
  EXPECT_EQ(bus.malformed_messages(), 1U);
  const auto got = received(b);
  ASSERT_EQ(got.size(), 1U) << "only the frame";
  EXPECT_EQ(got[0].id, 0x181U);
}

// ---- the bus budget of several nodes -----------------------------------------

TEST(CanopenBusBudget, OneSyncAndEveryNodesPdosAgainstThePeriodWithTheFigures) {
  const std::array<std::uint8_t, 2> two = {1, 2};
  const std::array<canopen::CyclicMapping, 2> mappings = {canopen::standard_mapping(1, false),
                                                          canopen::standard_mapping(2, false)};
  // SYNC 55 bits, RPDO1 (4 bytes) 95, TPDO1 (6 bytes) 115, worst-case stuffing:
  // 55 + 2 x 210 = 475, + 135 for one frame of other traffic = 610 bits.
  const co::BusBudget at_500us = canopen::bus_budget_for_nodes(mappings, two, 500e-6, 1000000);
  EXPECT_FALSE(at_500us.fits);
  EXPECT_EQ(at_500us.cyclic_bits, 475U);
  EXPECT_EQ(at_500us.total_bits, 610U);
  EXPECT_EQ(
      at_500us.summary,
      "2 drives on one bus (nodes 1, 2, one SYNC): 5 frames (SYNC + RPDO1 + TPDO1 + RPDO1 + TPDO1) = 475 "
      "bits worst case, + 135 bits for one frame of other traffic = 0.61 ms at 1 Mbit/s: a 0.5 ms "
      "period needs 1.22 Mbit/s, above classic CAN's 1 Mbit/s; the shortest period at 1 Mbit/s is "
      "0.61 ms");
  // One node alone fits there (SYNC + RPDO1 + TPDO1 + other = 400 bits).
  const co::BusBudget one =
      canopen::bus_budget_for_nodes(std::span(mappings).first(1), std::span(two).first(1), 500e-6, 1000000);
  EXPECT_TRUE(one.fits);
  EXPECT_EQ(one.total_bits, 400U);
  EXPECT_TRUE(canopen::bus_budget_for_nodes(mappings, two, 1e-3, 1000000).fits);
  // Six nodes with TPDO2 (4 bytes, 95 bits): 55 + 6 x (95 + 115 + 95) + 135 = 2020 bits: 2.02 ms at 1 Mbit/s.
  std::vector<canopen::CyclicMapping> six;
  std::vector<std::uint8_t> ids;
  for (std::uint8_t n = 1; n <= 6; ++n) {
    six.push_back(canopen::standard_mapping(n, true));
    ids.push_back(n);
  }
  const co::BusBudget b6 = canopen::bus_budget_for_nodes(six, ids, 2e-3, 1000000);
  EXPECT_EQ(b6.total_bits, 2020U);
  EXPECT_FALSE(b6.fits);
  EXPECT_TRUE(canopen::bus_budget_for_nodes(six, ids, 2.5e-3, 1000000).fits);
}

canopen::CanopenConfig two_node_config(const std::string& interface) {
  canopen::CanopenConfig c;
  c.interface = interface;
  c.node_ids = {1, 2};
  c.tpdo_timeout_periods = 5000;
  c.heartbeat_period = 0.02;
  c.heartbeat_timeout = 1.0;
  c.sdo_timeout = 2.0;
  return c;
}

/// Homing on a limit switch 0.7 m away at most: 1 m/s to it, 0.2 m/s off it.
canopen::CanopenConfig homing_config(const std::string& interface) {
  canopen::CanopenConfig c = two_node_config(interface);
  c.homing = true;
  c.homing_speed_switch = 1.0;
  c.homing_speed_zero = 0.2;
  c.homing_acceleration = 10.0;
  c.homing_timeout = 5.0;
  return c;
}

TEST(CanopenBusDevice, ConfigureRefusesAPeriodTheBusCannotCarryBeforeTouchingIt) {
  canopen::CanopenBusDevice device(two_node_config("unix:/nonexistent/bus"));
  try {
    device.configure({500e-6});
    FAIL() << "accepted";
  } catch (const hapticd::drivers::DeviceError& e) {
    EXPECT_EQ(e.key(), "bitrate");
    EXPECT_NE(std::string(e.what()).find("2 drives on one bus (nodes 1, 2, one SYNC): 5 frames"),
              std::string::npos)
        << e.what();
    EXPECT_NE(std::string(e.what()).find("= 0.61 ms at 1 Mbit/s: a 0.5 ms period needs 1.22 Mbit/s"),
              std::string::npos)
        << e.what();
  }
}

TEST(CanopenBusConfig, TheKeysOfSeveralDrivesAreCheckedNamingTheKey) {
  const auto refused_key = [](const canopen::CanopenConfig& c) -> std::string {
    try {
      canopen::validate(c);
    } catch (const canopen::ConfigError& e) {
      return e.key() + ": " + e.what();
    }
    return "accepted";
  };
  canopen::CanopenConfig c = two_node_config("unix:/x");
  EXPECT_EQ(refused_key(c), "accepted");
  c.node_ids = {1, 1};
  EXPECT_EQ(refused_key(c), "node_ids: node_ids: node 1 is named twice; each axis has its own drive");
  c.node_ids = {1, 127};
  EXPECT_EQ(refused_key(c),
            "node_ids: node_ids: node 127 is master_node_id: hapticd's heartbeat needs its own");
  c.node_ids = {1, 2, 3, 4, 5, 6, 7};
  EXPECT_EQ(
      refused_key(c),
      "node_ids: node_ids names 7 drive(s); accepted: 2 to 6 node-IDs, one per axis (one drive: node_id)");
  c.node_ids = {1, 2};
  c.axis_mass = {0.1};
  EXPECT_EQ(refused_key(c), "axis_mass: axis_mass has 1 masses; accepted: one per node in node_ids (2)");
  c.axis_mass = {0.1, 0.3};
  c.homing = true;
  EXPECT_EQ(refused_key(c), "accepted") << "every node homes with the same method";
  c.axis_homing_method = {17, 18, 19};
  EXPECT_EQ(
      refused_key(c),
      "axis_homing_method: axis_homing_method has 3 homing methods; accepted: one per node in node_ids (2)");
  c.axis_homing_method = {17, 200};
  EXPECT_EQ(refused_key(c),
            "axis_homing_method: axis_homing_method: each method must be -128..127 (0x6098 is INTEGER8)");
  c.axis_homing_method = {17, 18};
  c.axis_home_offset = {0.25, 1e9};  // 1e9 m at 16384 increments per metre: beyond INTEGER32
  const std::string offset = refused_key(c);
  EXPECT_EQ(offset.rfind("axis_home_offset: axis 2: home_offset = ", 0), 0U) << offset;
  EXPECT_NE(offset.find("beyond 0x607C"), std::string::npos) << offset;
  c.axis_home_offset = {0.25, -0.1};
  EXPECT_EQ(refused_key(c), "accepted") << "each node its own method and offset";
  canopen::CanopenConfig one;
  one.interface = "can0";
  one.axis_mass = {0.1, 0.2};
  EXPECT_EQ(refused_key(one),
            "axis_mass: axis_mass is for several drives (node_ids = \"1,2\"); one drive: mass");
  one.axis_mass.clear();
  one.axis_homing_method = {17, 18};
  EXPECT_EQ(refused_key(one),
            "axis_homing_method: axis_homing_method is for several drives (node_ids = "
            "\"1,2\"); one drive: homing_method");
}

// ---- two simulated drives as members of the bus, the driver's hooks ----------

class RigidPlant final : public sim::DrivePlant {
 public:
  explicit RigidPlant(double mass) : mass_(mass) {}
  double position() const override { return x; }
  double velocity() const override { return v; }
  void step(double force) override {
    const double a = (force - 0.05 * v) / mass_;
    x += v * period_s + 0.5 * a * period_s * period_s;
    v += a * period_s;
  }
  std::atomic<double> x = 0.0, v = 0.0;  // stepped by the bus member's thread

 private:
  double mass_;
};

sim::DriveSettings drive_settings(std::uint8_t node) {
  sim::DriveSettings s;
  s.node_id = node;
  s.rated_torque_mnm = 1000;
  s.supported_modes |= 1U << 5;  // homing too
  s.limit_switches = {-0.5, 0.5};
  s.moving_mass = node == 1 ? 0.1 : 0.3;  // the plants' masses below
  return s;
}

class TwoDrivesOnTheBus : public ::testing::Test {
 protected:
  TwoDrivesOnTheBus()
      : path(unique_path()),
        bus(path),
        plant1(0.1),
        plant2(0.3),
        drive1(drive_settings(1), plant1),
        drive2(drive_settings(2), plant2) {
    threads.emplace_back([this] { bus.run(stop, 1ms); });
    member1 = std::make_unique<sim::DriveBus>(sim::DriveBus::Member{}, path, drive1);
    member2 = std::make_unique<sim::DriveBus>(sim::DriveBus::Member{}, path, drive2);
    threads.emplace_back([this] { member1->run(stop); });
    threads.emplace_back([this] { member2->run(stop); });
    EXPECT_TRUE(eventually([&] { return bus.members() == 2U; }));
  }
  ~TwoDrivesOnTheBus() override {
    stop_loop();
    if (device) device->close();
    stop = true;
    for (auto& t : threads) t.join();
  }
  void open() {
    device = std::make_unique<canopen::CanopenBusDevice>(two_node_config("unix:" + path));
    device->configure({period_s});
    ASSERT_TRUE(eventually([&] { return bus.members() == 3U; }));
  }
  /// The RT loop in its own thread: read every axis, the forces, write.
  void start_loop(double f1, double f2) {
    forces[0] = f1;
    forces[1] = f2;
    loop_stop = false;
    loop = std::thread([this] {
      auto next = std::chrono::steady_clock::now();
      std::array<Reading, 2> r;
      while (!loop_stop) {
        last_read = device->read_axes(r);
        const std::array<double, 2> f = {forces[0].load(), forces[1].load()};
        device->write_axes(f);
        next += 1ms;
        std::this_thread::sleep_until(next);
      }
    });
  }
  void stop_loop() {
    loop_stop = true;
    if (loop.joinable()) loop.join();
  }

  std::string path;
  sim::CanBus bus;
  RigidPlant plant1, plant2;
  sim::SimulatedDrive drive1, drive2;
  std::unique_ptr<sim::DriveBus> member1, member2;
  std::atomic<bool> stop{false};
  std::vector<std::thread> threads;
  std::unique_ptr<canopen::CanopenBusDevice> device;
  std::thread loop;
  std::atomic<bool> loop_stop{false};
  std::array<std::atomic<double>, 2> forces{};
  std::atomic<IoResult> last_read{IoResult::ok};
};

TEST_F(TwoDrivesOnTheBus, EveryNodeHomesInTheSamePeriodsAndTorqueFlowsAfterInCyclicSynchronousTorque) {
  // Method 17 (the negative limit switch): each drive moves its own plant to
  // the switch at -0.5 m and backs off it; both in the same periods.
  plant1.x = 0.2;
  plant2.x = -0.1;
  canopen::CanopenConfig c = homing_config("unix:" + path);
  c.homing_method = 17;
  c.home_offset = 0.25;
  device = std::make_unique<canopen::CanopenBusDevice>(c);
  device->configure({period_s});
  device->enable();
  const auto homing = device->homing();
  ASSERT_TRUE(homing.has_value());
  EXPECT_EQ(homing->method, 17);
  EXPECT_EQ(homing->description, "CiA 402 homing method 17 (on the negative limit switch) on nodes 1, 2");
  // The farther plant (0.7 m at 1 m/s, then off the switch at 0.2 m/s) sets the time.
  EXPECT_GT(homing->periods, 700u);
  EXPECT_LT(homing->periods, 3000u);
  std::printf("two nodes homed on their negative switches in %llu periods\n",
              static_cast<unsigned long long>(homing->periods));
  for (const double x : {plant1.x.load(), plant2.x.load()}) {
    EXPECT_GT(x, -0.5) << "off the switch";
    EXPECT_NEAR(x, -0.5, 0.05);
  }
  // Each drive measures from its own switch's edge: the home reads -home_offset.
  start_loop(0.0, 0.0);
  std::array<Reading, 2> r;
  std::this_thread::sleep_for(20ms);
  stop_loop();
  ASSERT_EQ(device->read_axes(r), IoResult::ok);
  EXPECT_NEAR(r[0].position, -0.25 + (plant1.x + 0.5), 0.002);
  EXPECT_NEAR(r[1].position, -0.25 + (plant2.x + 0.5), 0.002);
  EXPECT_NEAR(homing->home_position, -0.25 + (plant1.x + 0.5), 0.002) << "axis 1's first reading after it";
  // Both back in mode 10: each axis' torque reaches its own drive.
  start_loop(0.3, -0.6);
  EXPECT_TRUE(eventually([&] {
    return std::abs(member1->applied_force() - 0.3) < 1e-3 && std::abs(member2->applied_force() + 0.6) < 1e-3;
  })) << member1->applied_force()
      << " " << member2->applied_force();
}

TEST_F(TwoDrivesOnTheBus, EachNodeHomesWithItsOwnMethodAndOffset) {
  // Node 1 on its negative switch (method 17), node 2 on its positive one
  // (18), each with its own 0x607C: each measures from its own switch's edge.
  plant1.x = 0.2;
  plant2.x = -0.1;
  canopen::CanopenConfig c = homing_config("unix:" + path);
  c.axis_homing_method = {17, 18};
  c.axis_home_offset = {0.25, -0.1};
  device = std::make_unique<canopen::CanopenBusDevice>(c);
  device->configure({period_s});
  device->enable();
  const auto homing = device->homing();
  ASSERT_TRUE(homing.has_value());
  EXPECT_EQ(homing->method, 17) << "axis 1's";
  EXPECT_EQ(homing->description,
            "CiA 402 homing: node 1 method 17 (on the negative limit switch), node 2 method 18 (on the "
            "positive limit switch)");
  std::printf("node 1 on its negative switch, node 2 on its positive one: %llu periods\n",
              static_cast<unsigned long long>(homing->periods));
  EXPECT_GT(plant1.x, -0.5) << "off the negative switch";
  EXPECT_NEAR(plant1.x, -0.5, 0.05);
  EXPECT_LT(plant2.x, 0.5) << "off the positive switch";
  EXPECT_NEAR(plant2.x, 0.5, 0.05);
  start_loop(0.0, 0.0);
  std::array<Reading, 2> r;
  std::this_thread::sleep_for(20ms);
  stop_loop();
  ASSERT_EQ(device->read_axes(r), IoResult::ok);
  EXPECT_NEAR(r[0].position, -0.25 + (plant1.x + 0.5), 0.002);
  EXPECT_NEAR(r[1].position, 0.1 + (plant2.x - 0.5), 0.002);
}

TEST_F(TwoDrivesOnTheBus, ANodeThatCannotHomeIsNamedWithItsAxisAndKey) {
  canopen::CanopenConfig c = two_node_config("unix:" + path);
  c.homing = true;
  c.homing_method = 1;  // on the index pulse: these drives have none
  device = std::make_unique<canopen::CanopenBusDevice>(c);
  device->configure({period_s});
  try {
    device->enable();
    FAIL() << "homed without an index pulse";
  } catch (const hapticd::drivers::DeviceError& e) {
    EXPECT_EQ(e.key(), "homing_method") << e.what();
    EXPECT_NE(std::string(e.what()).find("0x6098"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(device->homing().has_value());
}

TEST_F(TwoDrivesOnTheBus, ANodeWhoseOwnMethodItLacksIsNamedWithItsAxisAndThePerAxisKey) {
  canopen::CanopenConfig c = two_node_config("unix:" + path);
  c.homing = true;
  c.axis_homing_method = {37, 1};  // node 2 on the index pulse: it has none
  device = std::make_unique<canopen::CanopenBusDevice>(c);
  device->configure({period_s});
  try {
    device->enable();
    FAIL() << "homed without an index pulse";
  } catch (const hapticd::drivers::DeviceError& e) {
    EXPECT_EQ(e.key(), "axis_homing_method") << e.what();
    EXPECT_EQ(std::string(e.what()).rfind("axis 2: ", 0), 0U) << e.what();
  }
  EXPECT_FALSE(device->homing().has_value());
}

TEST_F(TwoDrivesOnTheBus, CommissioningReadsTheNamedNodesObjectsThroughTheLoop) {
  plant1.x = 0.2;
  plant2.x = -0.1;
  open();
  device->enable();
  // No loop: nothing would drain the answer off the socket.
  EXPECT_THROW((void)device->sdo_read(2, {0x6061, 0}, std::nullopt), std::invalid_argument);
  start_loop(0.0, 0.0);
  const canopen::SdoAccess mode = device->sdo_read(2, {0x6061, 0}, std::nullopt);
  EXPECT_EQ(mode.value, 10) << "cyclic synchronous torque";
  EXPECT_EQ(mode.name, "modes of operation display");
  // Each node answers for its own plant (0x6064: node 1's at +0.2, node 2's at -0.1).
  EXPECT_GT(device->sdo_read(1, {0x6064, 0}, std::nullopt).value, 0);
  EXPECT_LT(device->sdo_read(2, {0x6064, 0}, std::nullopt).value, 0);
  try {
    (void)device->sdo_read(5, {0x6061, 0}, std::nullopt);
    FAIL() << "read a node that is not on the bus";
  } catch (const std::invalid_argument& e) {
    EXPECT_STREQ(e.what(), "node 5 is not one of this device's drives; accepted: node_ids 1, 2");
  }
  EXPECT_EQ(last_read.load(), IoResult::ok) << "the loop ran on through the transfers";
  stop_loop();
}

TEST_F(TwoDrivesOnTheBus, CommissioningWritesRescaleOnlyTheNamedNodeAndWhatScalesTheTorqueWaitsForDisable) {
  open();
  device->enable();
  start_loop(0.3, -0.6);
  try {
    (void)device->sdo_write(2, {0x6076, 0}, 2000, std::nullopt);
    FAIL() << "rescaled a drive while enabled";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("0x6076:00 motor rated torque: the scale of every torque", 0), 0U)
        << e.what();
  }
  stop_loop();
  device->disable();
  start_loop(0.0, 0.0);
  const canopen::SdoAccess a = device->sdo_write(2, {0x6076, 0}, 2000, std::nullopt);
  EXPECT_EQ(
      a.note,
      "node 2's 0x6076 motor rated torque is now 2000 mN m (was 1000): hapticd scales axis 2's torque by "
      "it from now on");
  EXPECT_EQ(device->sdo_read(2, {0x6076, 0}, std::nullopt).value, 2000);
  EXPECT_EQ(device->sdo_read(1, {0x6076, 0}, std::nullopt).value, 1000) << "node 1 untouched";
  stop_loop();
  device->enable();
  // Node 2 gets -300 per mille of its new 2 N m (not -600 of the old 1 N m): -0.6 N m either way.
  start_loop(0.3, -0.6);
  EXPECT_TRUE(eventually([&] {
    return std::abs(member1->applied_force() - 0.3) < 1e-3 && std::abs(member2->applied_force() + 0.6) < 1e-3;
  })) << member1->applied_force()
      << " " << member2->applied_force();
  EXPECT_EQ(device->exchange_status(1).torque_permille, -300);
  EXPECT_EQ(device->exchange_status(0).torque_permille, 300);
}

TEST_F(TwoDrivesOnTheBus, EachAxisTorqueReachesItsOwnDriveAndNothingAllocatesPerPeriod) {
  open();
  EXPECT_EQ(device->axes(), 2);
  EXPECT_EQ(device->model().axes.size(), 2U);
  device->enable();
  EXPECT_EQ(drive1.nmt_state(), sim::NmtState::operational);
  EXPECT_EQ(drive2.nmt_state(), sim::NmtState::operational);
  std::size_t allocations = 0;
  int failures = 0;
  auto next = std::chrono::steady_clock::now();
  std::array<Reading, 2> r;
  for (int i = 0; i < 1000; ++i) {
    {
      hapticd::testing::AllocationGuard guard;
      const std::array<double, 2> f = {0.01, -0.02};
      const IoResult read = device->read_axes(r);
      const IoResult write = device->write_axes(f);
      allocations += guard.count();
      failures += (read != IoResult::ok) + (write != IoResult::ok);
    }
    next += 1ms;
    std::this_thread::sleep_until(next);
  }
  EXPECT_TRUE(hapticd::testing::allocation_counting_active());
  EXPECT_EQ(allocations, 0U);
  EXPECT_EQ(failures, 0) << device->health().fault_reason;
  // Each node's RPDO1 carried its own axis' torque, per mille of its 0x6076 (1 N m).
  EXPECT_TRUE(eventually([&] { return member1->applied_force() == 0.01; })) << member1->applied_force();
  EXPECT_TRUE(eventually([&] { return member2->applied_force() == -0.02; })) << member2->applied_force();
  EXPECT_EQ(device->exchange_status(0).torque_permille, 10);
  EXPECT_EQ(device->exchange_status(1).torque_permille, -20);
  // One SYNC for both: each drive counted the same SYNCs, and each axis reads its own plant.
  EXPECT_EQ(drive1.counters().syncs, drive2.counters().syncs);
  EXPECT_GT(r[0].position, 0.0);
  EXPECT_LT(r[1].position, 0.0);
}

TEST_F(TwoDrivesOnTheBus, AnEmcyOnOneNodeZeroesEveryAxisNamingTheAxisAndClearsThroughTheLoop) {
  open();
  device->enable();
  start_loop(0.2, 0.3);
  ASSERT_TRUE(eventually([&] { return member1->applied_force() == 0.2 && member2->applied_force() == 0.3; }));
  EXPECT_EQ(member2->command("fault 0x2310"), "ok EMCY 0x2310: continuous over current (motor side)");
  ASSERT_TRUE(eventually([&] { return device->health().faulted; }));
  EXPECT_EQ(last_read.load(), IoResult::fault);
  const std::string reason = device->health().fault_reason;
  EXPECT_EQ(reason.rfind("axis 2 (node 2): node 2 EMCY 0x2310: continuous over current (motor side)", 0), 0U)
      << reason;
  EXPECT_NE(reason.find("every axis held at zero"), std::string::npos) << reason;
  // The healthy node's torque is zero too, though the loop still asks for 0.2 N m.
  EXPECT_TRUE(eventually([&] { return member1->applied_force() == 0.0; })) << member1->applied_force();
  EXPECT_EQ(device->exchange_status(0).torque_permille, 0);
  EXPECT_FALSE(device->exchange_status(0).faulted) << "node 1 itself is fine";
  EXPECT_EQ(member2->applied_force(), 0.0);

  EXPECT_EQ(device->clear_fault(), reason);
  EXPECT_FALSE(device->health().faulted);
  EXPECT_TRUE(eventually([&] { return member1->applied_force() == 0.2 && member2->applied_force() == 0.3; }))
      << member1->applied_force() << " " << member2->applied_force();
  EXPECT_EQ(drive2.state(), sim::DriveState::operation_enabled);
}

}  // namespace

}  // namespace canbus_test
