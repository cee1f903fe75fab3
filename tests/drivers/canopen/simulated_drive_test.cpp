// The simulated CiA 402 drive, frame by frame: what a drive following CiA
// 301/402 answers, checked against the standard's bytes and rules (the
// driver is not involved here).
#include <gtest/gtest.h>

#include <cstdint>
#include <optional>
#include <vector>

#include "drivers/canopen/301/cob_id.hpp"
#include "drivers/canopen/301/emcy.hpp"
#include "drivers/canopen/301/nmt.hpp"
#include "drivers/canopen/301/pdo.hpp"
#include "drivers/canopen/301/sdo.hpp"
#include "sim/canopen/commands.hpp"
#include "sim/canopen/simulated_drive.hpp"

namespace simulated_drive_test {

namespace co = hapticd::drivers::canopen::cia301;
namespace sim = hapticd::drivers::canopen::sim;
using co::Frame;
using namespace std::chrono_literals;

namespace {

constexpr std::uint8_t node = 5;
constexpr std::uint8_t master = 127;
constexpr double period_s = 1e-3;

/// A rigid inertia advanced exactly for a force held over the period.
class RigidPlant final : public sim::DrivePlant {
 public:
  explicit RigidPlant(double inertia) : inertia_(inertia) {}
  double position() const override { return x_; }
  double velocity() const override { return v_; }
  void step(double force) override {
    const double a = force / inertia_;
    x_ += v_ * period_s + 0.5 * a * period_s * period_s;
    v_ += a * period_s;
    forces.push_back(force);
  }
  void set_position(double x) { x_ = x; }
  std::vector<double> forces;

 private:
  double inertia_;
  double x_ = 0.0, v_ = 0.0;
};

Frame make(std::uint32_t id, std::initializer_list<std::uint8_t> bytes) {
  Frame f;
  f.id = id;
  f.len = static_cast<std::uint8_t>(bytes.size());
  std::size_t i = 0;
  for (const std::uint8_t b : bytes) f.data[i++] = b;
  return f;
}

class SimulatedDriveTest : public ::testing::Test {
 protected:
  SimulatedDriveTest() : plant(0.01), drive(settings(), plant) { drive.power_on(now, out); }

  static sim::DriveSettings settings() {
    sim::DriveSettings s;
    s.node_id = node;
    s.vendor_id = 0x12345678;
    s.product_code = 0x402;
    s.revision = 0x00010002;
    s.serial = 4711;
    s.rated_torque_mnm = 500;       // 0.5 N m
    s.position_units_per_si = 1e4;  // 10000 increments per rad
    return s;
  }

  std::vector<Frame> send(const Frame& f) {
    out.clear();
    drive.on_frame(f, now, out);
    return out;
  }
  /// The one SDO response to a request.
  co::SdoResponse sdo(const Frame& request) {
    const auto frames = send(request);
    EXPECT_EQ(frames.size(), 1U);
    if (frames.empty()) return {};
    const auto r = co::decode_sdo_response(frames[0], node);
    EXPECT_TRUE(r);
    return r.value_or(co::SdoResponse{});
  }
  std::uint32_t read(co::ObjectAddress a) {
    const auto r = sdo(co::encode_upload_request(node, a));
    EXPECT_EQ(r.kind, co::SdoResponse::Kind::upload_expedited)
        << co::to_string(a) << " abort " << std::hex << r.abort_code;
    return r.value;
  }
  /// 0 when acknowledged, else the abort code.
  std::uint32_t write(co::ObjectAddress a, std::uint32_t value, std::uint8_t size) {
    const auto r = sdo(co::encode_download_expedited(node, a, value, size));
    return r.kind == co::SdoResponse::Kind::download_ack ? 0 : r.abort_code;
  }
  void write_all(const std::vector<co::SdoWrite>& writes) {
    for (const co::SdoWrite& w : writes)
      ASSERT_EQ(write(w.address, w.value, w.size), 0U) << co::to_string(w.address);
  }

  /// The driver's mapping: RPDO1 controlword + target torque, TPDO1 statusword + position, both on every
  /// SYNC.
  void configure_cyclic_torque() {
    const co::MappingEntry rx[] = {{{0x6040, 0}, 16}, {{0x6071, 0}, 16}};
    const co::MappingEntry tx[] = {{{0x6041, 0}, 16}, {{0x6064, 0}, 32}};
    write_all(co::pdo_configuration_sequence({co::PdoDirection::receive, 1, 0x205, 1, co::PdoLayout(rx)}));
    write_all(co::pdo_configuration_sequence({co::PdoDirection::transmit, 1, 0x185, 1, co::PdoLayout(tx)}));
    ASSERT_EQ(write({0x6060, 0}, 10, 1), 0U);
    send(co::encode_nmt(co::NmtCommand::start, node));
    ASSERT_EQ(drive.nmt_state(), sim::NmtState::operational);
  }
  /// One period as the driver does it: RPDO, then SYNC; returns what the drive sent.
  std::vector<Frame> cycle(std::uint16_t controlword, std::int16_t torque_permille) {
    now += 1ms;
    std::vector<Frame> frames = send(make(
        0x205, {static_cast<std::uint8_t>(controlword & 0xFF), static_cast<std::uint8_t>(controlword >> 8),
                static_cast<std::uint8_t>(torque_permille & 0xFF),
                static_cast<std::uint8_t>((torque_permille >> 8) & 0xFF)}));
    const auto sync = send(co::encode_sync());
    frames.insert(frames.end(), sync.begin(), sync.end());
    return frames;
  }
  static std::optional<Frame> find(const std::vector<Frame>& frames, std::uint32_t id) {
    for (const Frame& f : frames)
      if (f.id == id) return f;
    return std::nullopt;
  }
  void enable() {
    cycle(0x06, 0);
    cycle(0x07, 0);
    cycle(0x0F, 0);
    ASSERT_EQ(drive.state(), sim::DriveState::operation_enabled);
  }

  sim::Micros now{1000000};
  std::vector<Frame> out;
  RigidPlant plant;
  sim::SimulatedDrive drive;
};

}  // namespace

TEST_F(SimulatedDriveTest, PowerOnSendsBootUpAndWaitsPreOperational) {
  ASSERT_EQ(out.size(), 1U);
  EXPECT_EQ(out[0], make(0x705, {0x00}));
  EXPECT_EQ(drive.nmt_state(), sim::NmtState::pre_operational);
  EXPECT_EQ(drive.state(), sim::DriveState::switch_on_disabled);
  // PDOs are not active before NMT start: an RPDO and a SYNC produce nothing.
  EXPECT_TRUE(send(make(0x205, {0x06, 0x00})).empty());
  EXPECT_TRUE(send(co::encode_sync()).empty());
}

TEST_F(SimulatedDriveTest, AnswersIdentityAndDeviceType) {
  EXPECT_EQ(send(co::encode_upload_request(node, {0x1000, 0}))[0],
            make(0x585, {0x43, 0x00, 0x10, 0x00, 0x92, 0x01, 0x02, 0x00}));  // servo drive, CiA 402
  EXPECT_EQ(read({0x1018, 0}), 4U);
  EXPECT_EQ(read({0x1018, 1}), 0x12345678U);
  EXPECT_EQ(read({0x1018, 2}), 0x402U);
  EXPECT_EQ(read({0x1018, 3}), 0x00010002U);
  EXPECT_EQ(read({0x1018, 4}), 4711U);
  EXPECT_EQ(read({0x6076, 0}), 500U);
  EXPECT_EQ(read({0x6502, 0}), 1U << 9);
  // Switch On Disabled with voltage (bit 4) and remote (bit 9).
  EXPECT_EQ(send(co::encode_upload_request(node, {0x6041, 0}))[0],
            make(0x585, {0x4B, 0x41, 0x60, 0x00, 0x50, 0x02, 0x00, 0x00}));
}

TEST_F(SimulatedDriveTest, AbortsWithTheStandardCodes) {
  EXPECT_EQ(sdo(co::encode_upload_request(node, {0x2000, 0})).abort_code, co::abort_code::no_object);
  EXPECT_EQ(sdo(co::encode_upload_request(node, {0x1018, 5})).abort_code, co::abort_code::no_sub_index);
  EXPECT_EQ(write({0x6041, 0}, 0, 2), co::abort_code::read_only);
  EXPECT_EQ(write({0x6060, 0}, 10, 2), co::abort_code::length_too_high);
  EXPECT_EQ(write({0x6076, 0}, 10, 2), co::abort_code::length_too_low);
  EXPECT_EQ(write({0x6060, 0}, 8, 1), co::abort_code::invalid_value);  // CSP not supported by this drive
  EXPECT_EQ(write({0x6007, 0}, 7, 2), co::abort_code::invalid_value);
  EXPECT_EQ(write({0x1016, 1}, co::encode_consumer_heartbeat(master, 100), 4), 0U);
  EXPECT_EQ(write({0x1016, 2}, co::encode_consumer_heartbeat(master, 200), 4),
            co::abort_code::parameter_incompatible);
  // An abort frame is byte-exact: 0x80, index, sub, code.
  EXPECT_EQ(send(co::encode_upload_request(node, {0x2000, 0}))[0],
            make(0x585, {0x80, 0x00, 0x20, 0x00, 0x00, 0x00, 0x02, 0x06}));
  // A segmented download is not served by this expedited server.
  EXPECT_EQ(sdo(make(0x605, {0x21, 0x08, 0x10, 0x00, 0x10, 0, 0, 0})).abort_code,
            co::abort_code::unknown_command);
}

TEST_F(SimulatedDriveTest, PdoMappingFollowsTheStandardRules) {
  // The factory mapping is valid: changing it without disabling the PDO is refused.
  EXPECT_EQ(write({0x1600, 0}, 0, 1), co::abort_code::wrong_state);
  EXPECT_EQ(write({0x1400, 1}, 0x40000206, 4), co::abort_code::invalid_value);  // new id while valid
  ASSERT_EQ(write({0x1400, 1}, 0xC0000205, 4), 0U);
  EXPECT_EQ(write({0x1600, 1}, 0x60710010, 4), co::abort_code::wrong_state);  // count not yet 0
  ASSERT_EQ(write({0x1600, 0}, 0, 1), 0U);
  EXPECT_EQ(write({0x1600, 1}, 0x60410010, 4), co::abort_code::not_mappable);   // statusword is TPDO-only
  EXPECT_EQ(write({0x1600, 1}, 0x60710020, 4), co::abort_code::not_mappable);   // wrong length
  EXPECT_EQ(write({0x1600, 1}, 0x20000010, 4), co::abort_code::not_mappable);   // no such object
  EXPECT_EQ(write({0x1400, 1}, 0x40000205, 4), co::abort_code::invalid_value);  // valid with nothing mapped
  EXPECT_EQ(write({0x1400, 2}, 241, 1), co::abort_code::invalid_value);         // reserved type
  ASSERT_EQ(write({0x1A00, 1}, 0, 4), co::abort_code::wrong_state);             // TPDO1 still valid
  ASSERT_EQ(write({0x1800, 1}, 0xC0000185, 4), 0U);
  ASSERT_EQ(write({0x1A00, 0}, 0, 1), 0U);
  for (std::uint8_t s = 1; s <= 3; ++s) ASSERT_EQ(write({0x1A00, s}, 0x60640020, 4), 0U);
  EXPECT_EQ(write({0x1A00, 0}, 3, 1), co::abort_code::mapping_too_long);  // 96 bits
  EXPECT_EQ(write({0x1A00, 0}, 9, 1), co::abort_code::mapping_too_long);
  EXPECT_EQ(write({0x1A00, 0}, 2, 1), 0U);
  EXPECT_EQ(write({0x1800, 1}, 0x40000185, 4), 0U);
  EXPECT_EQ(write({0x1800, 1}, 0x40000705, 4), co::abort_code::invalid_value);  // heartbeat id is restricted
}

TEST_F(SimulatedDriveTest, CyclicTorqueWithOnePeriodOfDelay) {
  configure_cyclic_torque();
  enable();
  plant.forces.clear();
  plant.set_position(0.0);
  // Period n: RPDO with 400 per mille, then SYNC n. The TPDO of SYNC n carries
  // the position before the torque acts; the plant then moves under 0.2 N m.
  auto frames = cycle(0x0F, 400);
  const auto tpdo = find(frames, 0x185);
  ASSERT_TRUE(tpdo);
  EXPECT_EQ(*tpdo,
            make(0x185, {0x37, 0x12, 0x00, 0x00, 0x00, 0x00}));  // Operation Enabled, following; position 0
  ASSERT_EQ(plant.forces.size(), 1U);
  EXPECT_DOUBLE_EQ(plant.forces[0], 0.4 * 0.5);
  EXPECT_DOUBLE_EQ(drive.applied_force(), 0.2);
  // The next TPDO shows where that torque took the plant: x = a T^2 / 2 = 20 rad/s^2 * 1e-6 / 2 = 1e-5 rad =
  // 0.1 increments.
  plant.set_position(1e-3);  // move it by hand to see the sampling: 10 increments
  frames = cycle(0x0F, -400);
  EXPECT_EQ(*find(frames, 0x185), make(0x185, {0x37, 0x12, 0x0A, 0x00, 0x00, 0x00}));
  EXPECT_DOUBLE_EQ(plant.forces[1], -0.2);
  plant.set_position(-2e-4);  // -2 increments: INTEGER32 little-endian
  frames = cycle(0x0F, 0);
  EXPECT_EQ(*find(frames, 0x185), make(0x185, {0x37, 0x12, 0xFE, 0xFF, 0xFF, 0xFF}));
}

TEST_F(SimulatedDriveTest, HaltBitAndModeGateTheTorque) {
  configure_cyclic_torque();
  enable();
  cycle(0x10F, 500);  // halt
  EXPECT_EQ(drive.applied_force(), 0.0);
  cycle(0x0F, 500);
  EXPECT_DOUBLE_EQ(drive.applied_force(), 0.25);
  cycle(0x0F, 5000);  // above 0x6072 = 300 %: clamped
  EXPECT_DOUBLE_EQ(drive.applied_force(), 1.5);
  cycle(0x07, 500);  // Disable Operation: power stage off
  EXPECT_EQ(drive.state(), sim::DriveState::switched_on);
  EXPECT_EQ(drive.applied_force(), 0.0);
}

TEST_F(SimulatedDriveTest, RefusedModeIsAcknowledgedButNotDisplayed) {
  drive.refuse_mode(true);
  EXPECT_EQ(write({0x6060, 0}, 10, 1), 0U);
  EXPECT_EQ(read({0x6060, 0}), 10U);
  EXPECT_EQ(read({0x6061, 0}), 0U);
  drive.clear_switches();
  EXPECT_EQ(write({0x6060, 0}, 10, 1), 0U);
  EXPECT_EQ(read({0x6061, 0}), 10U);
}

TEST_F(SimulatedDriveTest, InjectedFaultSendsEmcyAndResetsOnTheEdge) {
  configure_cyclic_torque();
  enable();
  out.clear();
  drive.inject_fault({0x2310, std::nullopt}, now, out);
  ASSERT_EQ(out.size(), 1U);
  EXPECT_EQ(out[0], make(0x085, {0x10, 0x23, 0x03, 0x00, 0x00, 0x00, 0x00, 0x00}));  // generic + current
  EXPECT_EQ(drive.state(), sim::DriveState::fault_reaction_active);
  auto frames = cycle(0x0F, 400);
  EXPECT_EQ(drive.state(), sim::DriveState::fault);
  EXPECT_EQ(drive.applied_force(), 0.0);
  EXPECT_EQ(*find(frames, 0x185), make(0x185, {0x18, 0x02, 0x00, 0x00, 0x00, 0x00}));  // Fault
  EXPECT_EQ(read({0x603F, 0}), 0x2310U);
  EXPECT_EQ(drive.fault_reason(), "EMCY 0x2310: continuous over current (motor side)");
  // A level on bit 7 does nothing; the 0 -> 1 edge resets, with the EMCY "error reset".
  cycle(0x80, 0);
  EXPECT_EQ(drive.state(), sim::DriveState::switch_on_disabled);  // 0x0F -> 0x80 is an edge
  drive.inject_fault({0x4310, std::nullopt}, now, out);
  cycle(0x80, 0);
  cycle(0x80, 0);
  EXPECT_EQ(drive.state(), sim::DriveState::fault);  // bit 7 held high: no edge
  cycle(0x00, 0);
  frames = cycle(0x80, 0);
  EXPECT_EQ(drive.state(), sim::DriveState::switch_on_disabled);
  EXPECT_EQ(*find(frames, 0x085), make(0x085, {0, 0, 0, 0, 0, 0, 0, 0}));
  EXPECT_EQ(read({0x603F, 0}), 0U);
  EXPECT_EQ(drive.fault_reason(), "");
}

TEST_F(SimulatedDriveTest, QuickStopEndsInSwitchOnDisabledUnlessTheOptionCodeKeepsIt) {
  configure_cyclic_torque();
  enable();
  // Quick Stop (controlword 0 x 0 1 x, here 0x0B): transition 11.
  ASSERT_EQ(write({0x6040, 0}, 0x0B, 2), 0U);
  EXPECT_EQ(drive.state(), sim::DriveState::quick_stop_active);
  EXPECT_EQ(read({0x6041, 0}) & 0x6FU, 0x07U);  // bit 5 clear: quick stop active
  // 0x605A = 2 (quick stop ramp, then Switch On Disabled): in torque mode
  // the torque is zero at once, so at the SYNC it is done (transition 12).
  cycle(0x0B, 400);
  EXPECT_EQ(drive.state(), sim::DriveState::switch_on_disabled);
  EXPECT_EQ(drive.applied_force(), 0.0);
  // 0x605A = 6 stays in Quick Stop Active; Enable Operation leaves it (transition 16).
  ASSERT_EQ(write({0x605A, 0}, 6, 2), 0U);
  enable();
  cycle(0x0B, 400);
  EXPECT_EQ(drive.state(), sim::DriveState::quick_stop_active);
  EXPECT_EQ(drive.applied_force(), 0.0);
  cycle(0x0F, 400);
  EXPECT_EQ(drive.state(), sim::DriveState::operation_enabled);
}

TEST_F(SimulatedDriveTest, OnlyTheRisingEdgeOfBit7IsACommandWhileItIsHigh) {
  configure_cyclic_torque();
  drive.inject_fault({0x2310, std::nullopt}, now, out);
  cycle(0x00, 0);
  cycle(0x80, 0);  // the edge: transition 15
  EXPECT_EQ(drive.state(), sim::DriveState::switch_on_disabled);
  // CiA 402's commands other than Fault Reset have bit 7 = 0: 0x86 is no Shutdown.
  cycle(0x86, 0);
  EXPECT_EQ(drive.state(), sim::DriveState::switch_on_disabled);
  cycle(0x06, 0);
  EXPECT_EQ(drive.state(), sim::DriveState::ready_to_switch_on);
}

TEST_F(SimulatedDriveTest, ExpeditedDownloadWithoutSizeAndShortRequests) {
  // e = 1, s = 0 (0x22): the size is not indicated, the object's is taken.
  EXPECT_EQ(send(make(0x605, {0x22, 0x60, 0x60, 0x00, 10, 0, 0, 0})).at(0),
            make(0x585, {0x60, 0x60, 0x60, 0x00, 0, 0, 0, 0}));
  EXPECT_EQ(read({0x6061, 0}), 10U);
  // n = 2 with s = 1 (0x2B): two data bytes.
  EXPECT_EQ(write({0x6072, 0}, 0x1234, 2), 0U);
  EXPECT_EQ(send(co::encode_upload_request(node, {0x6072, 0})).at(0),
            make(0x585, {0x4B, 0x72, 0x60, 0x00, 0x34, 0x12, 0x00, 0x00}));
  // An SDO frame is 8 bytes: a shorter one is no request, and gets no answer.
  EXPECT_TRUE(send(make(0x605, {0x40, 0x00, 0x10, 0x00})).empty());
}

TEST_F(SimulatedDriveTest, HeartbeatProducer) {
  ASSERT_EQ(write({0x1017, 0}, 10, 2), 0U);
  out.clear();
  drive.tick(now, out);
  ASSERT_EQ(out.size(), 1U);
  EXPECT_EQ(out[0], make(0x705, {0x7F}));
  out.clear();
  now += 9ms;
  drive.tick(now, out);
  EXPECT_TRUE(out.empty());
  now += 1ms;
  drive.tick(now, out);
  ASSERT_EQ(out.size(), 1U);
  send(co::encode_nmt(co::NmtCommand::stop, node));
  out.clear();
  now += 10ms;
  drive.tick(now, out);
  EXPECT_EQ(out.at(0), make(0x705, {0x04}));
  // Stopped: SDO is silent.
  EXPECT_TRUE(send(co::encode_upload_request(node, {0x1000, 0})).empty());
}

TEST_F(SimulatedDriveTest, HeartbeatConsumerFaultsTheDriveWhenTheMasterDies) {
  configure_cyclic_torque();
  ASSERT_EQ(write({0x1016, 1}, co::encode_consumer_heartbeat(master, 50), 4), 0U);
  ASSERT_EQ(write({0x6007, 0}, 1, 2), 0U);  // fault signal
  enable();
  // No heartbeat yet: monitoring has not started.
  now += 200ms;
  out.clear();
  drive.tick(now, out);
  EXPECT_EQ(drive.state(), sim::DriveState::operation_enabled);
  // Heartbeats every 20 ms keep it alive.
  for (int i = 0; i < 5; ++i) {
    now += 20ms;
    send(co::encode_heartbeat(master, co::NmtState::operational));
    drive.tick(now, out);
  }
  EXPECT_EQ(drive.state(), sim::DriveState::operation_enabled);
  // The master dies: at 50 ms it is still alive, just after it is not.
  now += 50ms;
  out.clear();
  drive.tick(now, out);
  EXPECT_EQ(drive.state(), sim::DriveState::operation_enabled);
  now += 1ms;
  drive.tick(now, out);
  ASSERT_EQ(out.size(), 1U);
  EXPECT_EQ(out[0], make(0x085, {0x30, 0x81, 0x11, 0, 0, 0, 0, 0}));  // 0x8130, generic + communication
  EXPECT_EQ(drive.state(), sim::DriveState::fault_reaction_active);
  EXPECT_EQ(drive.nmt_state(), sim::NmtState::pre_operational);  // 0x1029 default
  EXPECT_EQ(drive.fault_reason(), "heartbeat of node 127 lost (consumer time 50 ms)");
  EXPECT_EQ(drive.applied_force(), 0.0);
}

TEST_F(SimulatedDriveTest, WithoutAbortConnectionOptionTheDriveKeepsGoing) {
  // 0x6007 = 0 (the factory value here): the heartbeat loss is reported, the state stays.
  configure_cyclic_torque();
  ASSERT_EQ(write({0x1016, 1}, co::encode_consumer_heartbeat(master, 50), 4), 0U);
  enable();
  send(co::encode_heartbeat(master, co::NmtState::operational));
  now += 51ms;
  out.clear();
  drive.tick(now, out);
  EXPECT_EQ(out.at(0).id, 0x085U);
  EXPECT_EQ(drive.state(), sim::DriveState::operation_enabled);
}

TEST_F(SimulatedDriveTest, DroppedTpdosAbortedSdoAndBusOff) {
  configure_cyclic_torque();
  drive.drop_tpdos(2);
  EXPECT_FALSE(find(cycle(0x06, 0), 0x185));
  EXPECT_FALSE(find(cycle(0x06, 0), 0x185));
  EXPECT_TRUE(find(cycle(0x06, 0), 0x185));
  EXPECT_EQ(drive.counters().tpdos_dropped, 2U);

  drive.abort_next_sdo(sim::Address{0x6060, 0}, co::abort_code::wrong_state);
  EXPECT_EQ(read({0x1000, 0}), 0x00020192U);  // another object: answered
  EXPECT_EQ(write({0x6060, 0}, 10, 1), co::abort_code::wrong_state);
  EXPECT_EQ(write({0x6060, 0}, 10, 1), 0U);  // once

  out.clear();
  drive.go_bus_off(now, out);
  ASSERT_FALSE(out.empty());
  EXPECT_EQ(out[0].id, co::can_err_flag | 0x40U);  // CAN_ERR_BUSOFF
  EXPECT_TRUE(drive.muted());
  EXPECT_TRUE(send(co::encode_upload_request(node, {0x1000, 0})).empty());
  EXPECT_TRUE(send(co::encode_sync()).empty());
}

TEST_F(SimulatedDriveTest, NmtResetCommunicationRestoresTheFactoryMapping) {
  configure_cyclic_torque();
  const auto frames = send(co::encode_nmt(co::NmtCommand::reset_communication, 0));  // broadcast
  ASSERT_EQ(frames.size(), 1U);
  EXPECT_EQ(frames[0], make(0x705, {0x00}));
  EXPECT_EQ(drive.nmt_state(), sim::NmtState::pre_operational);
  EXPECT_EQ(read({0x1600, 0}), 1U);
  EXPECT_EQ(read({0x1600, 1}), 0x60400010U);
  EXPECT_EQ(read({0x1400, 1}), 0x40000205U);
  EXPECT_EQ(read({0x6060, 0}), 10U);  // the application keeps its objects
}

TEST_F(SimulatedDriveTest, TextCommandsSetTheSwitches) {
  configure_cyclic_torque();
  out.clear();
  EXPECT_EQ(sim::apply_command(drive, "fault 0x3210", now, out), "ok EMCY 0x3210: DC link over-voltage");
  ASSERT_EQ(out.size(), 1U);
  EXPECT_EQ(out[0], make(0x085, {0x10, 0x32, 0x05, 0, 0, 0, 0, 0}));  // generic + voltage
  EXPECT_EQ(
      sim::apply_command(drive, "sdo-abort 0x6060:0 0x08000022", now, out),
      "ok the next SDO request for 0x6060:00 gets abort 0x08000022 (data cannot be stored in the drive's "
      "present state)");
  EXPECT_EQ(write({0x6060, 0}, 10, 1), co::abort_code::wrong_state);
  EXPECT_EQ(sim::apply_command(drive, "drop-tpdo all", now, out), "ok dropping every TPDO");
  EXPECT_FALSE(find(cycle(0x0F, 0), 0x185));
  EXPECT_EQ(sim::apply_command(drive, "clear", now, out), "ok switches cleared");
  EXPECT_TRUE(find(cycle(0x0F, 0), 0x185));
  const std::string bad = sim::apply_command(drive, "fault twelve", now, out);
  EXPECT_EQ(bad.rfind("error: fault needs an error code 0x0001..0xFFFF; accepted: fault <code>", 0), 0U)
      << bad;
  EXPECT_EQ(
      sim::apply_command(drive, "reboot", now, out).rfind("error: unknown command 'reboot'; accepted:", 0),
      0U);
  EXPECT_EQ(sim::apply_command(drive, "status", now, out).rfind("ok state=\"Fault\" nmt=operational", 0), 0U);
}

}  // namespace simulated_drive_test
