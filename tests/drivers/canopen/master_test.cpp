// The driver's own logic against the simulated drive, in one process and in
// simulated time: the SDO client, the drive setup (every step and its
// refusals), and the per-period exchange (enable, one period of delay,
// faults with the drive's reason, the reset edge, allocation-free).
#include <gtest/gtest.h>

#include <cmath>
#include <deque>
#include <numbers>
#include <vector>

#include "drivers/canopen/301/cob_id.hpp"
#include "drivers/canopen/301/nmt.hpp"
#include "drivers/canopen/301/sdo.hpp"
#include "drivers/canopen/cyclic_exchange.hpp"
#include "drivers/canopen/drive_setup.hpp"
#include "drivers/canopen/sdo_client.hpp"
#include "sim/canopen/simulated_drive.hpp"
#include "tests/support/alloc_counter.hpp"

namespace master_test {

namespace canopen = hapticd::drivers::canopen;
namespace co = hapticd::drivers::canopen::cia301;
namespace c4 = hapticd::drivers::canopen::cia402;
namespace sim = hapticd::drivers::canopen::sim;
using co::Frame;
using namespace std::chrono_literals;

namespace {

constexpr std::uint8_t node = 5;
constexpr std::uint8_t master = 127;
constexpr double period_s = 1e-3;

class RigidPlant final : public sim::DrivePlant {
 public:
  double position() const override { return x; }
  double velocity() const override { return v; }
  void step(double force) override {
    const double a = force / inertia;
    x += v * period_s + 0.5 * a * period_s * period_s;
    v += a * period_s;
  }
  double inertia = 0.01, x = 0.0, v = 0.0;
};

/// The bus between the driver's logic and the simulated drive, synchronous.
class SimLink final : public canopen::FrameLink {
 public:
  SimLink(sim::SimulatedDrive& drive, sim::Micros& now) : drive_(drive), now_(now) {}
  bool send(const Frame& f) override {
    sent.push_back(f);
    std::vector<Frame> out;
    drive_.on_frame(f, now_, out);
    inbox.insert(inbox.end(), out.begin(), out.end());
    return true;
  }
  bool receive(Frame& f, std::chrono::steady_clock::time_point) override {
    if (inbox.empty()) return false;  // nothing more will come: a timeout, without waiting
    f = inbox.front();
    inbox.pop_front();
    return true;
  }
  std::deque<Frame> inbox;
  std::vector<Frame> sent;

 private:
  sim::SimulatedDrive& drive_;
  sim::Micros& now_;
};

sim::DriveSettings drive_settings() {
  sim::DriveSettings s;
  s.node_id = node;
  s.vendor_id = 0xCAFE;
  s.rated_torque_mnm = 500;
  s.position_units_per_si = 16384.0 / (2.0 * std::numbers::pi);
  s.producer_heartbeat_ms = 0;
  return s;
}

class MasterTest : public ::testing::Test {
 protected:
  MasterTest() : drive(drive_settings(), plant), link(drive, now), sdo(link, node, 100ms) {
    std::vector<Frame> out;
    drive.power_on(now, out);
    link.inbox.assign(out.begin(), out.end());
    link.inbox.clear();  // the boot-up message
  }

  canopen::SetupOptions options() const {
    canopen::SetupOptions o;
    o.node = node;
    o.master_node = master;
    o.period_s = period_s;
    o.heartbeat_period_ms = 20;
    o.heartbeat_timeout_ms = 100;
    return o;
  }

  std::string setup_error(const canopen::SetupOptions& o, std::string* key = nullptr) {
    try {
      canopen::setup_drive(sdo, link, o);
    } catch (const canopen::SetupError& e) {
      if (key != nullptr) *key = e.key();
      return e.what();
    }
    return "";
  }

  /// Set up, start, and build the exchange the way the device does.
  void start(bool velocity = false) {
    canopen::SetupOptions o = options();
    o.velocity = velocity;
    result = canopen::setup_drive(sdo, link, o);
    link.send(co::encode_nmt(co::NmtCommand::start, node));
    canopen::CanopenConfig config;
    config.counts_per_unit = 16384;
    canopen::CyclicSettings s;
    s.node = node;
    s.master_node = master;
    s.mapping = result.mapping;
    s.scaling = canopen::scaling(config, result.rated_torque_mnm);
    s.tpdo_timeout_periods = 3;
    s.heartbeat_every_periods = 20;
    s.drive_heartbeat_timeout_periods = 100;
    s.reset_timeout_periods = 50;
    exchange.emplace(s);
    link.inbox.clear();
  }

  /// One period as the device runs it: drain, read, write.
  canopen::CycleReading period(double force) {
    now += 1ms;
    std::vector<Frame> out;
    drive.tick(now, out);
    link.inbox.insert(link.inbox.end(), out.begin(), out.end());
    while (!link.inbox.empty()) {
      exchange->on_frame(link.inbox.front());
      link.inbox.pop_front();
    }
    const canopen::CycleReading r = exchange->begin_period();
    std::array<Frame, 4> frames;
    const std::size_t n = exchange->end_period(force, frames);
    last_frames.assign(frames.begin(), frames.begin() + static_cast<std::ptrdiff_t>(n));
    for (const Frame& f : last_frames) link.send(f);
    return r;
  }

  void enable() {
    exchange->set_enabled(true);
    for (int i = 0; i < 10 && !exchange->operational(); ++i) period(0.0);
    ASSERT_TRUE(exchange->operational());
  }

  const Frame* rpdo() const {
    for (const Frame& f : last_frames)
      if (f.id == 0x205) return &f;
    return nullptr;
  }
  std::uint16_t sent_controlword() const {
    return static_cast<std::uint16_t>(rpdo()->data[0] | rpdo()->data[1] << 8);
  }
  std::int16_t sent_torque() const {
    return static_cast<std::int16_t>(rpdo()->data[2] | rpdo()->data[3] << 8);
  }

  sim::Micros now{5000000};
  RigidPlant plant;
  sim::SimulatedDrive drive;
  SimLink link;
  canopen::SdoClient sdo;
  canopen::SetupResult result;
  std::optional<canopen::CyclicExchange> exchange;
  std::vector<Frame> last_frames;
};

}  // namespace

// ---- SDO client --------------------------------------------------------------

TEST(CanopenSdoExchange, MatchesOnlyItsOwnAnswer) {
  auto e = canopen::SdoExchange::upload(node, {0x6061, 0});
  std::optional<Frame> reply;
  EXPECT_FALSE(
      e.on_frame(co::encode_upload_response(node, {0x6060, 0}, 10, 1), reply));        // other object: stale
  EXPECT_FALSE(e.on_frame(co::encode_upload_response(6, {0x6061, 0}, 10, 1), reply));  // other node
  EXPECT_TRUE(e.on_frame(co::encode_upload_response(node, {0x6061, 0}, 10, 1), reply));
  EXPECT_EQ(e.outcome().kind, canopen::SdoOutcome::Kind::ok);
  EXPECT_EQ(e.outcome().value, 10U);
  EXPECT_FALSE(reply);
  EXPECT_EQ(e.describe(), "SDO read 0x6061:00 from node 5: 10");
}

TEST(CanopenSdoExchange, AbortTimeoutAndSegmentedInWords) {
  auto w = canopen::SdoExchange::download(node, {0x1600, 1}, 0x60410010, 4);
  std::optional<Frame> reply;
  ASSERT_TRUE(w.on_frame(co::encode_server_abort(node, {0x1600, 1}, 0x06040041), reply));
  EXPECT_EQ(w.describe(),
            "SDO write 0x1600:01 = 0x60410010 to node 5: aborted 0x06040041 (the object cannot be mapped to "
            "the PDO)");

  auto t = canopen::SdoExchange::download(node, {0x6060, 0}, 10, 1);
  const Frame abort = t.time_out();
  EXPECT_EQ(abort, co::encode_client_abort(node, {0x6060, 0}, 0x05040000));  // CiA 301: the client aborts
  EXPECT_EQ(t.describe(), "SDO write 0x6060:00 = 10 to node 5: no answer");

  auto s = canopen::SdoExchange::upload(node, {0x1008, 0});
  Frame segmented = co::encode_upload_response(node, {0x1008, 0}, 0, 1);
  segmented.data[0] = 0x41;  // segmented initiate, size indicated
  segmented.data[4] = 11;
  ASSERT_TRUE(s.on_frame(segmented, reply));
  ASSERT_TRUE(reply);
  EXPECT_EQ(*reply, co::encode_client_abort(node, {0x1008, 0}, 0x06010000));
  EXPECT_EQ(s.outcome().kind, canopen::SdoOutcome::Kind::unsupported);
  EXPECT_EQ(
      s.describe(),
      "SDO read 0x1008:00 from node 5: the object is longer than 4 bytes (a segmented transfer of 11 bytes): "
      "only expedited SDO is supported");

  auto u = canopen::SdoExchange::upload(node, {0x6041, 0});
  ASSERT_TRUE(
      u.on_frame(co::encode_download_response(node, {0x6041, 0}), reply));  // a download ack to a read
  EXPECT_EQ(u.outcome().kind, canopen::SdoOutcome::Kind::unsupported);
  EXPECT_EQ(*reply, co::encode_client_abort(node, {0x6041, 0}, 0x05040001));
}

TEST_F(MasterTest, SdoClientTimesOutAndAbortsWhenTheDriveIsSilent) {
  drive.set_mute(true);
  try {
    sdo.read({0x1000, 0});
    FAIL();
  } catch (const canopen::SdoError& e) {
    EXPECT_EQ(std::string(e.what()), "SDO read 0x1000:00 from node 5: no answer within 100 ms");
  }
  ASSERT_EQ(link.sent.size(), 2U);
  EXPECT_EQ(link.sent[1], co::encode_client_abort(node, {0x1000, 0}, 0x05040000));
}

// ---- setup -------------------------------------------------------------------

TEST_F(MasterTest, SetupConfiguresTheDriveTheStandardWay) {
  const canopen::SetupResult r = canopen::setup_drive(sdo, link, options());
  EXPECT_EQ(r.identity.device_type, 0x00020192U);
  EXPECT_EQ(r.identity.vendor_id, 0xCAFEU);
  EXPECT_EQ(r.rated_torque_mnm, 500U);
  EXPECT_TRUE(r.rated_torque_from_drive);
  EXPECT_EQ(r.state, c4::DriveState::switch_on_disabled);
  EXPECT_TRUE(r.notes.empty());
  const sim::ObjectDictionary& od = drive.dictionary();
  EXPECT_EQ(od.get({0x6060, 0}), 10U);
  EXPECT_EQ(od.get({0x6061, 0}), 10U);
  EXPECT_EQ(od.get({0x60C2, 1}), 1U);
  EXPECT_EQ(od.get({0x60C2, 2}), 0xFDU);  // -3
  EXPECT_EQ(od.get({0x6007, 0}), 1U);
  EXPECT_EQ(od.get({0x1017, 0}), 20U);
  EXPECT_EQ(od.get({0x1016, 1}), 0x007F0064U);
  EXPECT_EQ(od.get({0x1400, 1}), 0x40000205U);
  EXPECT_EQ(od.get({0x1400, 2}), 1U);
  EXPECT_EQ(od.get({0x1600, 0}), 2U);
  EXPECT_EQ(od.get({0x1600, 1}), 0x60400010U);
  EXPECT_EQ(od.get({0x1600, 2}), 0x60710010U);
  EXPECT_EQ(od.get({0x1800, 1}), 0x40000185U);
  EXPECT_EQ(od.get({0x1A00, 0}), 2U);
  EXPECT_EQ(od.get({0x1A00, 1}), 0x60410010U);
  EXPECT_EQ(od.get({0x1A00, 2}), 0x60640020U);
  EXPECT_EQ(od.get({0x1801, 1}) >> 31, 1U);  // TPDO2 not valid: no velocity asked for
  EXPECT_EQ(od.get({0x1A01, 0}), 0U);
  EXPECT_EQ(od.get({0x1401, 1}) >> 31, 1U);
  EXPECT_EQ(drive.nmt_state(), sim::NmtState::pre_operational);
  // The mapping went out in the standard order: disable, type, count 0, entries, count, enable.
  std::vector<co::ObjectAddress> rpdo_writes;
  for (const Frame& f : link.sent) {
    const auto req = co::decode_sdo_request(f, node);
    if (req && req->kind == co::SdoRequest::Kind::download_expedited &&
        (req->address.index == 0x1400 || req->address.index == 0x1600))
      rpdo_writes.push_back(req->address);
  }
  const std::vector<co::ObjectAddress> expected = {{0x1400, 1}, {0x1400, 2}, {0x1600, 0}, {0x1600, 1},
                                                   {0x1600, 2}, {0x1600, 0}, {0x1400, 1}};
  EXPECT_EQ(rpdo_writes, expected);
}

TEST_F(MasterTest, SetupResetsAFaultLeftFromBeforeAndSaysSo) {
  std::vector<Frame> out;
  drive.inject_fault({0x8130, std::nullopt}, now, out);  // as after a killed hapticd
  const canopen::SetupResult r = canopen::setup_drive(sdo, link, options());
  EXPECT_EQ(r.state, c4::DriveState::switch_on_disabled);
  ASSERT_EQ(r.notes.size(), 1U);
  EXPECT_EQ(r.notes[0], "reset the fault the drive had: 0x603F = 0x8130 (life guard or heartbeat error)");
  EXPECT_EQ(drive.error_code(), 0U);
}

TEST_F(MasterTest, SetupMapsVelocityOnlyWhenAskedFor) {
  canopen::SetupOptions o = options();
  o.velocity = true;
  const canopen::SetupResult r = canopen::setup_drive(sdo, link, o);
  ASSERT_TRUE(r.mapping.tpdo_velocity);
  EXPECT_EQ(drive.dictionary().get({0x1801, 1}), 0x40000285U);
  EXPECT_EQ(drive.dictionary().get({0x1A01, 1}), 0x606C0020U);
  EXPECT_EQ(canopen::cyclic_frames(r.mapping).size(), 4U);
}

TEST_F(MasterTest, SetupRefusalsNameTheReasonAndTheKey) {
  std::string key;
  drive.set_mute(true);
  EXPECT_EQ(setup_error(options(), &key),
            "node 5 does not answer: SDO read 0x1000:00 from node 5: no answer within 100 ms");
  EXPECT_EQ(key, "node_id");
  drive.clear_switches();

  drive.refuse_mode(true);
  EXPECT_EQ(setup_error(options(), &key),
            "node 5 did not take cyclic synchronous torque: after 0x6060 = 10, 0x6061 shows 0 (no mode)");
  drive.clear_switches();

  drive.abort_next_sdo(sim::Address{0x1600, 1}, co::abort_code::not_mappable);
  EXPECT_EQ(setup_error(options(), &key),
            "SDO write 0x1600:01 = 0x60400010 to node 5: aborted 0x06040041 (the object cannot be mapped to "
            "the PDO)");

  drive.abort_next_sdo(sim::Address{0x6060, 0}, co::abort_code::wrong_state);
  EXPECT_EQ(
      setup_error(options(), &key),
      "SDO write 0x6060:00 = 10 to node 5: aborted 0x08000022 (data cannot be stored in the drive's present "
      "state)");

  drive.abort_next_sdo(sim::Address{0x1016, 1}, co::abort_code::no_sub_index);
  EXPECT_EQ(
      setup_error(options(), &key),
      "node 5 has no heartbeat consumer (0x1016:01), so it could not stop when hapticd dies; refusing to "
      "drive "
      "it: SDO write 0x1016:01 = 0x007F0064 to node 5: aborted 0x06090011 (the sub-index does not exist)");
  EXPECT_EQ(key, "heartbeat_timeout");

  canopen::SetupOptions odd = options();
  odd.period_s = 333.3e-6;
  EXPECT_NE(setup_error(odd).find("has no exact 0x60C2 form"), std::string::npos);
}

TEST(CanopenSetup, RefusesADriveWithoutTheProfileOrTheMode) {
  sim::Micros now{0};
  RigidPlant plant;
  sim::DriveSettings s = drive_settings();
  s.device_type = 0x00000191;  // CiA 401 I/O module
  sim::SimulatedDrive io(s, plant);
  std::vector<Frame> out;
  io.power_on(now, out);
  SimLink link(io, now);
  canopen::SdoClient sdo(link, node, 100ms);
  canopen::SetupOptions o;
  o.node = node;
  try {
    canopen::setup_drive(sdo, link, o);
    FAIL();
  } catch (const canopen::SetupError& e) {
    EXPECT_EQ(std::string(e.what()),
              "node 5 is not a CiA 402 drive: 0x1000 device type = 0x00000191 (profile 401)");
  }

  s = drive_settings();
  s.supported_modes = 1U << 8;  // cyclic synchronous velocity only
  sim::SimulatedDrive csv(s, plant);
  csv.power_on(now, out);
  SimLink link2(csv, now);
  canopen::SdoClient sdo2(link2, node, 100ms);
  try {
    canopen::setup_drive(sdo2, link2, o);
    FAIL();
  } catch (const canopen::SetupError& e) {
    EXPECT_EQ(std::string(e.what()),
              "node 5 does not offer cyclic synchronous torque: 0x6502 supported drive modes = 0x00000100 "
              "(bit 9 clear)");
  }
}

// ---- the per-period exchange -------------------------------------------------

TEST_F(MasterTest, EnablesWithTheStandardSequenceAndHaltUntilACommandFlows) {
  start();
  period(0.0);                           // prime: the first TPDO
  EXPECT_EQ(sent_controlword(), 0x100);  // Disable Voltage + halt: not enabled yet
  exchange->set_enabled(true);
  std::vector<std::uint16_t> controlwords;
  for (int i = 0; i < 6; ++i) {
    period(0.0);
    controlwords.push_back(sent_controlword());
  }
  // Shutdown, Switch On, Enable Operation (halt while the drive is not yet enabled), then halt clear.
  const std::vector<std::uint16_t> expected = {0x106, 0x107, 0x10F, 0x00F, 0x00F, 0x00F};
  EXPECT_EQ(controlwords, expected);
  EXPECT_TRUE(exchange->operational());
  EXPECT_EQ(drive.state(), sim::DriveState::operation_enabled);
  period(std::nan(""));  // no valid command: halt, no torque
  EXPECT_EQ(sent_controlword(), 0x10F);
  EXPECT_EQ(sent_torque(), 0);
}

TEST_F(MasterTest, TorqueGoesOutPerMilleAndActsOnePeriodLater) {
  start();
  period(0.0);
  enable();
  // 0.2 N m of a 0.5 N m rated motor is 400 per mille.
  const double x0 = plant.x;
  const canopen::CycleReading before = period(0.2);
  EXPECT_EQ(sent_torque(), 400);
  EXPECT_DOUBLE_EQ(drive.applied_force(), 0.2);
  // The reading of the next period is the TPDO sampled at this period's SYNC, before the torque acted.
  const canopen::CycleReading same = period(0.0);
  EXPECT_TRUE(same.fresh);
  EXPECT_DOUBLE_EQ(same.position, before.position);
  EXPECT_NEAR(same.position, x0, 2 * std::numbers::pi / 16384);
  // One period further the torque's effect shows (quantized to increments).
  plant.x = 0.5;  // move it by hand to see the scaling: 0.5 rad = 1303.8 increments -> 1304
  period(0.0);
  const canopen::CycleReading moved = period(0.0);
  EXPECT_DOUBLE_EQ(moved.position, 1304 * 2 * std::numbers::pi / 16384);
  period(-10.0);  // beyond INTEGER16 per mille: clamped
  EXPECT_EQ(sent_torque(), -20000);
  EXPECT_DOUBLE_EQ(drive.applied_force(), -1.5);  // and the drive's 0x6072 = 300 % limits it
}

TEST_F(MasterTest, EmcyZeroesTheTorqueInThatPeriodAndNamesTheDrivesReason) {
  start();
  period(0.0);
  enable();
  period(0.2);
  std::vector<Frame> out;
  drive.inject_fault({0x2310, std::nullopt}, now, out);
  link.inbox.insert(link.inbox.end(), out.begin(), out.end());
  period(0.2);  // the EMCY is read at the start of this period
  EXPECT_TRUE(exchange->faulted());
  EXPECT_EQ(sent_torque(), 0);
  EXPECT_EQ(sent_controlword(), 0x100);  // Disable Voltage + halt
  EXPECT_EQ(
      canopen::describe(exchange->fault(), exchange->settings()),
      "node 5 EMCY 0x2310: continuous over current (motor side); error register 0x03 (generic, current); "
      "manufacturer bytes 00 00 00 00 00");
  for (int i = 0; i < 5; ++i) period(0.2);
  EXPECT_EQ(exchange->fault().kind, canopen::FaultKind::emcy);  // the first reason stays
  EXPECT_EQ(drive.state(), sim::DriveState::fault);

  // Fault reset: bit 7 low (it is: 0x100), then high; then the enable sequence.
  exchange->request_fault_reset();
  std::vector<std::uint16_t> controlwords;
  for (int i = 0; i < 10 && !exchange->operational(); ++i) {
    period(0.0);
    controlwords.push_back(sent_controlword());
  }
  EXPECT_TRUE(exchange->operational());
  ASSERT_GE(controlwords.size(), 4U);
  EXPECT_EQ(controlwords[0], 0x180);  // the edge
  EXPECT_EQ(controlwords[1] & 0x8F, 0x06);
  EXPECT_EQ(drive.state(), sim::DriveState::operation_enabled);
  EXPECT_EQ(drive.error_code(), 0U);
}

TEST_F(MasterTest, ALateTpdoIsCountedAMissingOneIsAFault) {
  start();
  period(0.0);
  enable();
  drive.drop_tpdos(1);
  period(0.1);
  const canopen::CycleReading late = period(0.1);
  EXPECT_FALSE(late.fresh);
  EXPECT_TRUE(late.valid);  // the last position stands
  EXPECT_FALSE(exchange->faulted());
  EXPECT_EQ(exchange->counters().late_tpdos, 1U);
  EXPECT_EQ(sent_torque(), 200);  // a late TPDO alone does not stop the command

  drive.drop_tpdos(3);
  period(0.1);
  period(0.1);
  period(0.1);
  EXPECT_FALSE(exchange->faulted());
  period(0.1);
  EXPECT_TRUE(exchange->faulted());
  EXPECT_EQ(sent_torque(), 0);
  EXPECT_EQ(canopen::describe(exchange->fault(), exchange->settings()),
            "no TPDO1 (0x185) from node 5 for 3 periods");
}

TEST_F(MasterTest, AKilledHapticdFaultsTheDriveThroughItsHeartbeatConsumer) {
  start();
  period(0.0);
  enable();
  for (int i = 0; i < 50; ++i) period(0.1);
  EXPECT_EQ(drive.state(), sim::DriveState::operation_enabled);
  // hapticd dies: no more frames. The drive's consumer (100 ms) fires.
  std::vector<Frame> out;
  for (int ms = 0; ms < 130; ++ms) {
    now += 1ms;
    drive.tick(now, out);
  }
  EXPECT_EQ(drive.state(), sim::DriveState::fault);  // 0x6007 = 1, written by the setup
  EXPECT_EQ(drive.applied_force(), 0.0);
  EXPECT_EQ(drive.fault_reason(), "heartbeat of node 127 lost (consumer time 100 ms)");
}

TEST_F(MasterTest, BusOffLatchesWithTheControllersWords) {
  start();
  period(0.0);
  enable();
  std::vector<Frame> out;
  drive.go_bus_off(now, out);
  link.inbox.insert(link.inbox.end(), out.begin(), out.end());
  period(0.1);
  EXPECT_TRUE(exchange->faulted());
  EXPECT_EQ(sent_torque(), 0);
  EXPECT_EQ(canopen::describe(exchange->fault(), exchange->settings()), "CAN bus-off");
}

TEST_F(MasterTest, AResetThatCannotEnableFailsInBoundedTime) {
  start();
  period(0.0);
  enable();
  drive.set_mute(true);
  for (int i = 0; i < 4; ++i) period(0.0);
  ASSERT_TRUE(exchange->faulted());
  exchange->request_fault_reset();
  for (int i = 0; i < 60; ++i) period(0.0);
  EXPECT_TRUE(exchange->faulted());
  EXPECT_EQ(exchange->fault().kind, canopen::FaultKind::reset_failed);
}

TEST_F(MasterTest, ThePeriodIsAllocationFree) {
  start();
  period(0.0);
  enable();
  std::size_t allocations = 0;
  std::array<Frame, 4> frames;
  for (int i = 0; i < 1000; ++i) {
    now += 1ms;
    std::vector<Frame> ticked;
    drive.tick(now, ticked);
    std::vector<Frame> incoming(link.inbox.begin(), link.inbox.end());
    incoming.insert(incoming.end(), ticked.begin(), ticked.end());
    link.inbox.clear();
    std::size_t n = 0;
    {
      hapticd::testing::AllocationGuard guard;
      for (const Frame& f : incoming) exchange->on_frame(f);
      exchange->begin_period();
      n = exchange->end_period(0.1 * std::sin(i * 0.01), frames);
      allocations += guard.count();
    }
    for (std::size_t k = 0; k < n; ++k) link.send(frames[k]);
  }
  EXPECT_TRUE(hapticd::testing::allocation_counting_active());
  EXPECT_EQ(allocations, 0U);
  EXPECT_TRUE(exchange->operational());
}

// Issue 17: what breaks CiA 301 zeroes the torque in the period it is read.
TEST_F(MasterTest, AMalformedEmcyHeartbeatOrMessageZeroesThatPeriodsTorque) {
  start();
  period(0.0);
  enable();
  Frame short_emcy;
  short_emcy.id = 0x085;
  short_emcy.len = 3;
  short_emcy.data = {0x10, 0x23, 0x00};
  Frame odd_state = co::encode_heartbeat(node, co::NmtState::operational);
  odd_state.data[0] = 0x33;
  Frame long_heartbeat = co::encode_heartbeat(node, co::NmtState::operational);
  long_heartbeat.len = 2;
  for (const Frame& attack : {short_emcy, odd_state, long_heartbeat}) {
    period(0.2);
    ASSERT_EQ(sent_torque(), 400);
    link.inbox.push_back(attack);
    period(0.2);  // read at the start of this period
    EXPECT_TRUE(exchange->faulted());
    EXPECT_EQ(exchange->fault().kind, canopen::FaultKind::malformed_frame);
    EXPECT_EQ(sent_torque(), 0);
    EXPECT_EQ(sent_controlword() & 0x100, 0x100);  // halt
    exchange->request_fault_reset();
    for (int i = 0; i < 10 && !exchange->operational(); ++i) period(0.0);
    ASSERT_TRUE(exchange->operational());
  }
  EXPECT_EQ(exchange->counters().malformed_frames, 3U);
  period(0.2);
  canopen::MalformedMessage m;
  m.bytes = 72;
  exchange->on_malformed_message(m);
  period(0.2);
  EXPECT_EQ(exchange->fault().kind, canopen::FaultKind::malformed_message);
  EXPECT_EQ(sent_torque(), 0);
  EXPECT_EQ(canopen::describe(exchange->fault(), exchange->settings()),
            "a 72-byte message on the CAN socket: not a can_frame (16 bytes)");
}

TEST_F(MasterTest, MalformedFramesKeepThePeriodAllocationFree) {
  start();
  period(0.0);
  enable();
  Frame short_emcy;
  short_emcy.id = 0x085;
  short_emcy.len = 2;
  Frame odd_state = co::encode_heartbeat(node, co::NmtState::operational);
  odd_state.data[0] = 0x33;
  Frame boot_up = co::encode_heartbeat(node, co::NmtState::boot_up);
  canopen::MalformedMessage empty;
  std::array<Frame, 4> frames;
  std::size_t allocations = 0;
  for (int i = 0; i < 4; ++i) {
    {
      hapticd::testing::AllocationGuard guard;
      if (i == 0) exchange->on_frame(short_emcy);
      if (i == 1) exchange->on_frame(odd_state);
      if (i == 2) exchange->on_frame(boot_up);
      if (i == 3) exchange->on_malformed_message(empty);
      exchange->on_torque_unit_changed(500, 5000);
      exchange->set_force_per_permille(5e-3);
      exchange->begin_period();
      exchange->end_period(0.1, frames);
      allocations += guard.count();
    }
    EXPECT_TRUE(exchange->faulted());
    exchange->request_fault_reset();
  }
  EXPECT_TRUE(hapticd::testing::allocation_counting_active());
  EXPECT_EQ(allocations, 0U);
}

// ---- the exchange alone, frame by frame ----------------------------------------

namespace {

canopen::CyclicSettings plain_settings() {
  canopen::CyclicSettings s;
  s.node = node;
  s.master_node = master;
  s.mapping = canopen::standard_mapping(node, false);
  s.scaling.si_per_count = 1.0;
  s.scaling.force_per_permille = 1e-3;
  s.tpdo_timeout_periods = 1000;
  s.heartbeat_every_periods = 3;
  s.drive_heartbeat_timeout_periods = 5;
  return s;
}

Frame tpdo(std::uint16_t sw, std::int32_t position) {
  Frame f;
  f.id = 0x185;
  f.len = 6;
  co::put_le(f.data, 0, sw, 2);
  co::put_le(f.data, 2, static_cast<std::uint32_t>(position), 4);
  return f;
}

}  // namespace

TEST(CanopenCyclicExchange, FramesOfAPeriodInOrder) {
  canopen::CyclicExchange x(plain_settings());
  x.on_frame(tpdo(0x0250, 0));
  x.begin_period();
  std::array<Frame, 4> out;
  ASSERT_EQ(x.end_period(0.0, out), 3U);  // RPDO, SYNC, heartbeat (due at once)
  Frame rpdo;
  rpdo.id = 0x205;
  rpdo.len = 4;
  rpdo.data[1] = 0x01;  // 0x0100: Disable Voltage + halt, torque 0
  EXPECT_EQ(out[0], rpdo);
  EXPECT_EQ(out[1], co::encode_sync());
  EXPECT_EQ(out[2], co::encode_heartbeat(master, co::NmtState::operational));
  EXPECT_EQ(x.end_period(0.0, out), 2U);
  EXPECT_EQ(x.end_period(0.0, out), 2U);
  EXPECT_EQ(x.end_period(0.0, out), 3U);  // every 3 periods
}

TEST(CanopenCyclicExchange, PositionUnwrapsAcrossTheInteger32Wrap) {
  canopen::CyclicExchange x(plain_settings());
  x.on_frame(tpdo(0x0250, 2147483600));
  EXPECT_DOUBLE_EQ(x.begin_period().position, 2147483600.0);
  x.on_frame(tpdo(0x0250, -2147483600));  // +96 counts through the wrap
  EXPECT_DOUBLE_EQ(x.begin_period().position, 2147483696.0);
  x.on_frame(tpdo(0x0250, 2147483000));  // -696 back
  EXPECT_DOUBLE_EQ(x.begin_period().position, 2147483000.0);
}

TEST(CanopenCyclicExchange, DriveHeartbeatWatched) {
  canopen::CyclicExchange x(plain_settings());
  x.on_frame(tpdo(0x0250, 0));
  x.begin_period();
  for (int i = 0; i < 20; ++i) x.begin_period();
  EXPECT_FALSE(x.faulted());  // monitoring starts with the first heartbeat
  x.on_frame(co::encode_heartbeat(node, co::NmtState::operational));
  for (int i = 0; i < 5; ++i) x.begin_period();
  EXPECT_FALSE(x.faulted());
  x.begin_period();
  ASSERT_TRUE(x.faulted());
  EXPECT_EQ(canopen::describe(x.fault(), x.settings()), "no heartbeat from node 5 for 6 periods");
}

TEST(CanopenCyclicExchange, DriveLeavingOperationalOrEnabledIsAFault) {
  canopen::CyclicExchange x(plain_settings());
  x.on_frame(co::encode_heartbeat(node, co::NmtState::pre_operational));  // before NMT start took effect
  x.on_frame(tpdo(0x0250, 0));
  x.begin_period();
  EXPECT_FALSE(x.faulted());
  x.on_frame(co::encode_heartbeat(node, co::NmtState::operational));
  x.on_frame(co::encode_heartbeat(node, co::NmtState::pre_operational));
  ASSERT_TRUE(x.faulted());
  EXPECT_EQ(canopen::describe(x.fault(), x.settings()),
            "node 5 left NMT operational: its heartbeat says pre-operational");

  canopen::CyclicExchange y(plain_settings());
  y.set_enabled(true);
  y.on_frame(tpdo(0x0237, 0));  // Operation Enabled
  y.begin_period();
  y.on_frame(tpdo(0x0250, 0));  // Switch On Disabled, no EMCY
  ASSERT_TRUE(y.faulted());
  EXPECT_EQ(canopen::describe(y.fault(), y.settings()),
            "node 5 left Operation Enabled on its own: statusword 0x0250 (Switch On Disabled)");

  canopen::CyclicExchange z(plain_settings());
  z.on_frame(tpdo(0x0218, 0));  // Fault; the EMCY arrives after: it gives the reason
  co::Emergency e;
  e.error_code = 0x4310;
  e.error_register = 0x09;
  z.on_frame(co::encode_emergency(node, e));
  EXPECT_EQ(z.fault().kind, canopen::FaultKind::emcy);
  EXPECT_EQ(z.fault().emcy.error_code, 0x4310);
  // The EMCY "error reset" (code 0) is no fault.
  canopen::CyclicExchange w(plain_settings());
  w.on_frame(co::encode_emergency(node, co::Emergency{}));
  EXPECT_FALSE(w.faulted());
}

// ---- config -------------------------------------------------------------------

TEST(CanopenConfig, RefusalsNameTheKey) {
  auto key_of = [](canopen::CanopenConfig c) -> std::string {
    try {
      canopen::validate(c);
    } catch (const canopen::ConfigError& e) {
      return e.key();
    }
    return "";
  };
  canopen::CanopenConfig ok;
  ok.interface = "can0";
  EXPECT_EQ(key_of(ok), "");
  auto with = [&](auto change) {
    canopen::CanopenConfig c = ok;
    change(c);
    return key_of(c);
  };
  EXPECT_EQ(with([](auto& c) { c.interface = ""; }), "interface");
  EXPECT_EQ(with([](auto& c) { c.interface = "unix:"; }), "interface");
  EXPECT_EQ(with([](auto& c) { c.node_id = 0; }), "node_id");
  EXPECT_EQ(with([](auto& c) { c.master_node_id = 1; }), "master_node_id");  // the drive's own id
  EXPECT_EQ(with([](auto& c) { c.bitrate = 2000000; }), "bitrate");
  EXPECT_EQ(with([](auto& c) { c.counts_per_unit = 0; }), "counts_per_unit");
  EXPECT_EQ(with([](auto& c) { c.heartbeat_timeout = c.heartbeat_period; }), "heartbeat_timeout");
  EXPECT_EQ(with([](auto& c) { c.heartbeat_period = 0.0001; }), "heartbeat_period");
  EXPECT_EQ(with([](auto& c) { c.tpdo_timeout_periods = 0; }), "tpdo_timeout_periods");
  EXPECT_EQ(with([](auto& c) { c.rated_torque = -1; }), "rated_torque");
}

TEST(CanopenConfig, ScalingFromDriveUnitsToSi) {
  canopen::CanopenConfig c;
  c.counts_per_unit = 4096;
  c.gear_ratio = 10.0;
  const canopen::Scaling s = canopen::scaling(c, 500);  // 0x6076 = 0.5 N m
  EXPECT_DOUBLE_EQ(s.si_per_count, 2 * std::numbers::pi / 4096);
  EXPECT_DOUBLE_EQ(s.si_per_velocity_unit, 2 * std::numbers::pi / 4096);  // increments/s by default
  EXPECT_DOUBLE_EQ(s.force_per_permille, 0.5e-3 * 10.0);                  // at the gearbox output
  c.reversed = true;
  c.motion = hapticd::drivers::Motion::linear;
  c.counts_per_unit = 1e6;  // 1 um increments
  c.velocity_counts_per_unit = 1e3;
  c.rated_torque = 20.0;  // N, overrides 0x6076
  const canopen::Scaling l = canopen::scaling(c, 500);
  EXPECT_DOUBLE_EQ(l.si_per_count, -1e-6);
  EXPECT_DOUBLE_EQ(l.si_per_velocity_unit, -1e-3);
  EXPECT_DOUBLE_EQ(l.force_per_permille, -20e-3 * 10.0);
}

}  // namespace master_test
