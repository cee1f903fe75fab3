// The driver's session over its real transport: the unix SOCK_SEQPACKET seam
// to the simulated drive's bus loop running in a thread, in real time. No
// timing is asserted: each check waits (bounded, generously) for a condition.
#include <gtest/gtest.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <mutex>
#include <thread>

#include "drivers/canopen/canopen_session.hpp"
#include "drivers/canopen/sim/drive_bus.hpp"
#include "drivers/canopen/sim/simulated_drive.hpp"
#include "tests/support/alloc_counter.hpp"

namespace canopen = hapticd::drivers::canopen;
namespace sim = hapticd::drivers::canopen::sim;
namespace co = hapticd::drivers::canopen::cia301;
using hapticd::drivers::IoResult;
using hapticd::drivers::Reading;
using namespace std::chrono_literals;

namespace {

constexpr double period_s = 1e-3;

class RigidPlant final : public sim::DrivePlant {
 public:
  double position() const override { return x; }
  double velocity() const override { return v; }
  void step(double force) override {
    const double a = (force - 0.05 * v) / 0.01;  // J = 0.01 kg m^2, a little damping
    x += v * period_s + 0.5 * a * period_s * period_s;
    v += a * period_s;
  }
  double x = 0.0, v = 0.0;
};

std::string unique_path() {
  static std::atomic<int> n{0};
  return (std::filesystem::temp_directory_path() /
          ("hapticd-canopen-bus-" + std::to_string(::getpid()) + "-" + std::to_string(n++)))
      .string();
}

// Generous: under TSan on this shared 2-vCPU VM (load 10) the drive's thread
// went without the CPU for seconds; it returns as soon as the condition holds.
template <class Condition>
bool eventually(Condition&& condition, std::chrono::milliseconds limit = 10000ms) {
  const auto deadline = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < deadline) {
    if (condition()) return true;
    std::this_thread::sleep_for(1ms);
  }
  return condition();
}

class SessionTest : public ::testing::Test {
 protected:
  SessionTest()
      : path(unique_path()), drive(settings(), plant), bus(std::make_unique<sim::DriveBus>(path, drive)) {
    thread = std::thread([this] { bus->run(stop); });
  }
  ~SessionTest() override {
    stop_loop();
    session.reset();
    stop = true;
    if (thread.joinable()) thread.join();
  }

  static sim::DriveSettings settings() {
    sim::DriveSettings s;
    s.node_id = 5;
    s.rated_torque_mnm = 500;
    return s;
  }
  canopen::CanopenConfig config() const {
    canopen::CanopenConfig c;
    c.interface = "unix:" + path;
    c.node_id = 5;
    // Under TSan on this loaded VM the drive's thread missed 200 periods; the
    // timeout test sets its own.
    c.tpdo_timeout_periods = 5000;
    c.heartbeat_period = 0.02;
    c.heartbeat_timeout = 1.0;  // both ways; the dead-man test sets 300 ms
    c.sdo_timeout = 2.0;        // the drive's thread went 500 ms unscheduled at load 10
    return c;
  }
  void open(const canopen::CanopenConfig& c) {
    session = std::make_unique<canopen::CanopenSession>(c);
    session->configure(period_s);
  }
  /// The RT loop, in its own thread: read, a force, write, every period.
  void start_loop(double force) {
    loop_force = force;
    loop_stop = false;
    loop = std::thread([this] {
      auto next = std::chrono::steady_clock::now();
      while (!loop_stop) {
        Reading r;
        last_read = session->read(r);
        session->write(loop_force.load());
        next += 1ms;
        std::this_thread::sleep_until(next);
      }
    });
  }
  void stop_loop() {
    loop_stop = true;
    if (loop.joinable()) loop.join();
  }
  std::string drive_status() { return bus ? bus->command("status") : "no bus"; }

  std::string path;
  RigidPlant plant;
  sim::SimulatedDrive drive;
  std::unique_ptr<sim::DriveBus> bus;
  std::atomic<bool> stop{false};
  std::thread thread;
  std::unique_ptr<canopen::CanopenSession> session;
  std::thread loop;
  std::atomic<bool> loop_stop{false};
  std::atomic<double> loop_force{0.0};
  std::atomic<IoResult> last_read{IoResult::ok};
};

}  // namespace

TEST_F(SessionTest, ConfigureEnableRunDisableClose) {
  open(config());
  EXPECT_EQ(session->setup().identity.device_type, 0x00020192U);
  EXPECT_EQ(session->setup().rated_torque_mnm, 500U);
  EXPECT_TRUE(session->budget().fits);
  Reading r;
  EXPECT_EQ(session->read(r), IoResult::ok);  // valid after configure: the primed TPDO
  EXPECT_EQ(session->write(0.0), IoResult::ok);
  session->enable();
  EXPECT_NE(drive_status().find("state=\"Operation Enabled\" nmt=operational"), std::string::npos);
  start_loop(0.1);
  EXPECT_TRUE(eventually([&] { return drive_status().find("force=0.1 ") != std::string::npos; }))
      << drive_status();
  EXPECT_TRUE(eventually([&] { return session->status().counters.tpdos > 100; }));
  stop_loop();
  const canopen::SessionStatus st = session->status();
  EXPECT_TRUE(st.operational);
  EXPECT_EQ(st.drive_state, "Operation Enabled");
  EXPECT_EQ(st.torque_permille, 200);
  session->disable();
  EXPECT_NE(drive_status().find("state=\"Switch On Disabled\""), std::string::npos) << drive_status();
  session->close();
  // NMT is unconfirmed: the drive's thread takes the command when it runs.
  EXPECT_TRUE(eventually([&] { return drive_status().find("nmt=pre-operational") != std::string::npos; }))
      << drive_status();
  session->close();  // idempotent
}

TEST_F(SessionTest, DisableWhileTheLoopStillRunsTakesThePowerStageOff) {
  open(config());
  session->enable();
  start_loop(0.1);
  ASSERT_TRUE(eventually([&] { return drive_status().find("force=0.1 ") != std::string::npos; }));
  session->disable();  // handed to the running loop
  EXPECT_TRUE(eventually([&] {
    return drive_status().find("state=\"Switch On Disabled\"") != std::string::npos;
  })) << drive_status();
  EXPECT_NE(drive_status().find("force=0 "), std::string::npos);
  stop_loop();
}

TEST_F(SessionTest, APeriodTheBusCannotCarryIsRefusedBeforeTouchingIt) {
  canopen::CanopenConfig c = config();
  c.interface = "unix:/nonexistent/bus";  // never reached
  c.bitrate = 250000;
  canopen::CanopenSession s(c);
  try {
    s.configure(1e-3);
    FAIL();
  } catch (const canopen::SetupError& e) {
    EXPECT_EQ(e.key(), "bitrate");
    EXPECT_EQ(
        std::string(e.what()),
        "3 frames (SYNC + RPDO1 + TPDO1) = 265 bits worst case, + 135 bits for one frame of other traffic = "
        "1.6 ms at 250 kbit/s: a 1 ms period needs 500 kbit/s; the shortest period at 250 kbit/s is 1.6 ms");
  }
  c.bitrate = 1000000;
  canopen::CanopenSession t(c);
  try {
    t.configure(1e-3);
    FAIL();
  } catch (const canopen::SetupError& e) {
    EXPECT_EQ(e.key(), "interface");
  }
}

TEST_F(SessionTest, EmcyFaultsInThatPeriodAndClearRecoversWhileTheLoopRuns) {
  open(config());
  session->enable();
  start_loop(0.1);
  ASSERT_TRUE(eventually([&] { return drive_status().find("force=0.1 ") != std::string::npos; }));
  EXPECT_EQ(bus->command("fault 0x2310").rfind("ok", 0), 0U);
  ASSERT_TRUE(eventually([&] { return last_read.load() == IoResult::fault; }));
  // read() saw it; the status is published by that period's write().
  ASSERT_TRUE(eventually([&] { return session->status().faulted; }));
  const canopen::SessionStatus st = session->status();
  EXPECT_EQ(
      st.fault_reason,
      "node 5 EMCY 0x2310: continuous over current (motor side); error register 0x03 (generic, current); "
      "manufacturer bytes 00 00 00 00 00");
  EXPECT_EQ(st.torque_permille, 0);
  EXPECT_EQ(st.controlword, 0x100);
  EXPECT_NE(drive_status().find("force=0 "), std::string::npos);
  loop_force = 0.0;  // the engine holds zero while latched
  const std::string cleared = session->clear_fault();
  EXPECT_EQ(cleared, st.fault_reason);
  EXPECT_TRUE(session->status().operational);
  EXPECT_TRUE(eventually([&] { return last_read.load() == IoResult::ok; }));
  EXPECT_NE(drive_status().find("state=\"Operation Enabled\""), std::string::npos);
}

TEST_F(SessionTest, ClearFaultWaitsForTheResetTheLoopTookToBePublished) {
  // The loop takes a clear at read() and publishes its status at write(): a
  // loop thread preempted between the two (this VM does that under load) left
  // clear_fault() reading the old fault, not yet resetting, and throwing "the
  // drive stays in fault" with the EMCY it was clearing. Here the loop sleeps
  // 20 ms between read() and write() on purpose (10 ms period, so the loop is
  // still seen running).
  canopen::CanopenConfig c = config();
  session = std::make_unique<canopen::CanopenSession>(c);
  session->configure(10e-3);
  session->enable();
  loop_stop = false;
  loop = std::thread([this] {
    while (!loop_stop) {
      Reading r;
      last_read = session->read(r);
      std::this_thread::sleep_for(20ms);
      session->write(0.0);
    }
  });
  EXPECT_EQ(bus->command("fault 0x2310").rfind("ok", 0), 0U);
  ASSERT_TRUE(eventually([&] { return session->status().faulted; }));
  std::string cleared;
  EXPECT_NO_THROW(cleared = session->clear_fault());
  EXPECT_EQ(cleared.rfind("node 5 EMCY 0x2310", 0), 0U) << cleared;
  EXPECT_TRUE(session->status().operational);
  stop_loop();
}

TEST_F(SessionTest, MissingTpdosFaultWithTheCount) {
  canopen::CanopenConfig c = config();
  c.tpdo_timeout_periods = 20;
  open(c);
  session->enable();
  start_loop(0.05);
  ASSERT_TRUE(eventually([&] { return session->status().counters.tpdos > 20; }));
  bus->command("drop-tpdo all");
  ASSERT_TRUE(eventually([&] { return last_read.load() == IoResult::fault; }));
  // read() saw it; the status is published by that period's write().
  ASSERT_TRUE(eventually([&] { return session->status().faulted; }));
  EXPECT_EQ(session->status().fault_reason, "no TPDO1 (0x185) from node 5 for 20 periods");
  EXPECT_TRUE(eventually([&] { return drive_status().find("force=0 ") != std::string::npos; }));
  // While TPDOs stay away the reset cannot confirm the drive: clear fails, in words.
  loop_force = 0.0;
  try {
    session->clear_fault();
    FAIL();
  } catch (const canopen::SetupError& e) {
    EXPECT_EQ(
        std::string(e.what()).rfind("the drive stays in fault: the fault reset did not bring node 5 back to "
                                    "Operation Enabled within 1000 periods",
                                    0),
        0U)
        << e.what();
  }
  bus->command("clear");
  // The statusword in it is the last one seen before the reset gave up: when
  // TPDOs stopped, or one the drive sent as they resumed.
  EXPECT_EQ(
      session->clear_fault().rfind(
          "the fault reset did not bring node 5 back to Operation Enabled within 1000 periods: statusword 0x",
          0),
      0U);
  EXPECT_TRUE(session->status().operational);
}

TEST_F(SessionTest, AKilledDriveIsAFaultWithTheReason) {
  open(config());
  session->enable();
  start_loop(0.05);
  ASSERT_TRUE(eventually([&] { return session->status().counters.tpdos > 20; }));
  stop = true;  // the bus program ends: its sockets close
  thread.join();
  bus.reset();
  ASSERT_TRUE(eventually([&] { return last_read.load() == IoResult::fault; }));
  // read() saw it; the status is published by that period's write().
  ASSERT_TRUE(eventually([&] { return session->status().faulted; }));
  EXPECT_EQ(session->status().fault_reason,
            "the bus connection closed (the simulated drive's bus program ended?)");
}

TEST_F(SessionTest, AKilledHapticdLetsTheDrivesHeartbeatConsumerStopIt) {
  canopen::CanopenConfig c = config();
  c.heartbeat_timeout = 0.3;
  open(c);
  session->enable();
  start_loop(0.1);
  ASSERT_TRUE(eventually([&] { return drive_status().find("force=0.1 ") != std::string::npos; }));
  // The loop dies soon after enable, before its 20-period heartbeat: the
  // first heartbeat went out with enable, so the drive is watching already.
  stop_loop();  // no SYNC, no RPDO, no heartbeat any more (as after SIGKILL)
  EXPECT_TRUE(eventually([&] {
    return drive_status().find("fault=\"heartbeat of node 127 lost (consumer time 300 ms)\"") !=
           std::string::npos;
  })) << drive_status();
  EXPECT_TRUE(eventually([&] { return drive_status().find("state=\"Fault\"") != std::string::npos; }));
  EXPECT_NE(drive_status().find("force=0 "), std::string::npos);
  // hapticd restarts: the setup resets the fault it finds, says so, and enables.
  session.reset();
  open(config());
  ASSERT_FALSE(session->setup().notes.empty());
  EXPECT_EQ(session->setup().notes.back(),
            "reset the fault the drive had: 0x603F = 0x8130 (life guard or heartbeat error)");
  session->enable();
  EXPECT_TRUE(session->status().operational);
}

TEST_F(SessionTest, CommissioningReadsAndWritesRefusingTheMappingWhileEnabled) {
  open(config());
  const canopen::SdoAccess id = session->sdo_read({0x1018, 1}, std::nullopt);
  EXPECT_EQ(id.name, "vendor-ID");
  session->enable();
  start_loop(0.0);
  const canopen::SdoAccess sw = session->sdo_read({0x6041, 0}, std::nullopt);
  EXPECT_EQ(sw.type, co::DataType::unsigned16);
  EXPECT_EQ(sw.raw & 0x6F, 0x27U);  // Operation Enabled, read through the running loop
  try {
    session->sdo_write({0x1600, 1}, 0x60710010, std::nullopt);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()),
              "0x1600:01 is a PDO mapping parameter: changing it changes the cyclic exchange: refused while "
              "the drive "
              "is enabled");
  }
  EXPECT_THROW(session->sdo_write({0x6060, 0}, 8, std::nullopt), std::invalid_argument);
  const canopen::SdoAccess max = session->sdo_write({0x6072, 0}, 1500, std::nullopt);
  EXPECT_EQ(max.value, 1500);
  EXPECT_EQ(session->sdo_read({0x6072, 0}, std::nullopt).value, 1500);
  EXPECT_THROW(session->sdo_write({0x6072, 0}, 70000, std::nullopt), std::invalid_argument);  // not a u16
  bus->command("sdo-abort 0x6072:0 0x06090031");
  try {
    session->sdo_write({0x6072, 0}, 4000, std::nullopt);
    FAIL();
  } catch (const canopen::SdoError& e) {
    EXPECT_EQ(std::string(e.what()),
              "SDO write 0x6072:00 = 4000 to node 5: aborted 0x06090031 (value too high)");
  }
  EXPECT_TRUE(session->status().operational);  // commissioning did not disturb the loop
}

TEST_F(SessionTest, ReadAndWriteAreAllocationFreeOnTheSocket) {
  open(config());
  session->enable();
  std::size_t allocations = 0;
  auto next = std::chrono::steady_clock::now();
  for (int i = 0; i < 1000; ++i) {
    {
      hapticd::testing::AllocationGuard guard;
      Reading r;
      session->read(r);
      session->write(0.01);
      allocations += guard.count();
    }
    next += 1ms;
    std::this_thread::sleep_until(next);
  }
  EXPECT_EQ(allocations, 0U);
  EXPECT_TRUE(session->status().operational) << session->status().fault_reason;
}
