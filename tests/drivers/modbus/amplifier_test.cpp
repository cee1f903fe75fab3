// The simulated amplifier's protocol logic, driven with hand-built request
// PDUs (no sockets): writes before reads, one plant step per torque write,
// enable, faults, reset, watchdog, injected failures.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <vector>

#include "drivers/modbus/modbus_config.hpp"
#include "drivers/modbus/modbus_frame.hpp"
#include "loopback_plant.hpp"
#include "sim/modbus/amplifier.hpp"

namespace amplifier_test {

namespace mb = hapticd::drivers::modbus;
using mb::sim::Decision;

namespace {

class AmplifierTest : public ::testing::Test {
 protected:
  AmplifierTest() : config_(mb::modbus_config({})), amplifier_(settings(config_), plant_) {
    amplifier_.bind(holding_, input_, coils_);
  }

  static mb::sim::AmplifierSettings settings(const mb::ModbusConfig& c) {
    mb::sim::AmplifierSettings s;
    s.position_per_count = c.position_per_count();
    s.torque_per_count = c.torque_per_count;
    return s;
  }

  Decision request(const std::vector<std::uint8_t>& pdu, double now = 0.0) {
    return amplifier_.on_request(pdu, now);
  }

  std::vector<std::uint8_t> write_and_read(std::int16_t torque, std::uint16_t watchdog) {
    std::array<std::uint8_t, 64> pdu{};
    const std::uint16_t values[] = {static_cast<std::uint16_t>(torque), watchdog};
    const std::size_t n = mb::build_write_and_read_request(pdu, 0, 6, 10, values);
    return {pdu.begin(), pdu.begin() + static_cast<std::ptrdiff_t>(n)};
  }
  std::vector<std::uint8_t> write_register(std::uint16_t address, std::uint16_t value) {
    std::array<std::uint8_t, 8> pdu{};
    const std::size_t n = mb::build_write_single_register_request(pdu, address, value);
    return {pdu.begin(), pdu.begin() + static_cast<std::ptrdiff_t>(n)};
  }
  std::int32_t position_counts() const {
    return mb::join_words(holding_[0], holding_[1], mb::WordOrder::high_first);
  }

  mb::ModbusConfig config_;
  mb::testing::LoopbackPlant plant_;
  std::array<std::uint16_t, 64> holding_{}, input_{};
  std::array<std::uint8_t, 16> coils_{};
  mb::sim::Amplifier amplifier_;
};

}  // namespace

TEST_F(AmplifierTest, TorqueIsAppliedOnlyWhenEnabled) {
  EXPECT_EQ(request(write_and_read(500, 50)).kind, Decision::Kind::reply);
  EXPECT_EQ(amplifier_.state().steps, 1u);
  EXPECT_EQ(amplifier_.state().applied_torque, 0.0);  // power stage off
  EXPECT_EQ(holding_[4] & 1u, 0u);                    // status: not enabled
  request(write_register(12, 0x0001));                // control word, enable bit 0
  EXPECT_TRUE(amplifier_.state().enabled);
  EXPECT_EQ(holding_[4] & 1u, 1u);
  request(write_and_read(500, 50));
  EXPECT_DOUBLE_EQ(amplifier_.state().applied_torque, 0.5);  // 500 counts x 1 mN m
  EXPECT_EQ(amplifier_.state().steps, 2u);
}

TEST_F(AmplifierTest, OneStepPerTorqueWriteMovesThePositionRegisters) {
  request(write_register(12, 0x0001));
  EXPECT_EQ(position_counts(), 0);
  for (int i = 0; i < 100; ++i) request(write_and_read(800, 50));
  EXPECT_EQ(amplifier_.state().steps, 100u);
  // The registers hold the plant's own (quantized) position in counts.
  hapticd::drivers::Reading r;
  plant_.sense(r.position);
  EXPECT_GT(position_counts(), 0);
  EXPECT_EQ(position_counts(), std::llround(r.position / config_.position_per_count()));
  // A read alone does not step the plant.
  std::array<std::uint8_t, 8> read{};
  const std::size_t n = mb::build_read_registers_request(read, 0x03, 0, 6);
  request({read.begin(), read.begin() + static_cast<std::ptrdiff_t>(n)});
  EXPECT_EQ(amplifier_.state().steps, 100u);
}

TEST_F(AmplifierTest, ReplyCarriesTheStateAfterTheWrite) {
  request(write_register(12, 0x0001));
  const auto pdu = write_and_read(800, 50);
  request(pdu);
  std::array<std::uint8_t, 64> reply{};
  const std::size_t n = amplifier_.build_reply(pdu, reply);
  std::array<std::uint16_t, 6> expected{};
  for (std::size_t i = 0; i < 6; ++i) expected[i] = holding_[i];
  std::array<std::uint8_t, 64> built{};
  const std::size_t m = mb::build_write_and_read_response(built, expected);
  ASSERT_EQ(n, m);
  EXPECT_TRUE(std::equal(reply.begin(), reply.begin() + static_cast<std::ptrdiff_t>(n), built.begin()));
}

TEST_F(AmplifierTest, FaultDisablesAndResetClears) {
  request(write_register(12, 0x0001));
  amplifier_.inject_fault(0x0001);  // over-current
  request(write_and_read(800, 50));
  EXPECT_FALSE(amplifier_.state().enabled);
  EXPECT_EQ(amplifier_.state().applied_torque, 0.0);
  EXPECT_EQ(holding_[5], 0x0001);
  EXPECT_EQ(holding_[4] & 0x2u, 0x2u);  // status fault bit
  request(write_register(12, 0x0001));  // enabling in fault is refused
  EXPECT_FALSE(amplifier_.state().enabled);
  request(write_register(13, 1));  // reset register, reset value
  EXPECT_EQ(amplifier_.state().fault, 0);
  EXPECT_EQ(amplifier_.state().resets, 1u);
  EXPECT_FALSE(amplifier_.state().enabled);  // a reset does not re-enable
  request(write_register(12, 0x0001));
  EXPECT_TRUE(amplifier_.state().enabled);
}

TEST_F(AmplifierTest, WatchdogExpiresInWallTime) {
  request(write_register(12, 0x0001));
  request(write_and_read(100, 50), 10.0);  // armed: 50 ms
  EXPECT_TRUE(amplifier_.state().watchdog_armed);
  amplifier_.tick(10.049);
  EXPECT_TRUE(amplifier_.state().enabled);
  request(write_and_read(100, 50), 10.049);  // refreshed by the write
  amplifier_.tick(10.098);
  EXPECT_TRUE(amplifier_.state().enabled);
  amplifier_.tick(10.100);  // 51 ms after the last refresh
  EXPECT_FALSE(amplifier_.state().enabled);
  EXPECT_EQ(amplifier_.state().watchdog_trips, 1u);
  EXPECT_EQ(amplifier_.state().fault, 1u << 2);                 // the watchdog bit
  EXPECT_NEAR(amplifier_.state().trip_silence_s, 0.051, 1e-9);  // what it saw of the silence
  request(write_register(11, 0));                               // disarm, then reset and enable
  request(write_register(13, 1));
  request(write_register(12, 0x0001));
  EXPECT_TRUE(amplifier_.state().enabled);
}

TEST_F(AmplifierTest, InjectedFailuresDecideTheReply) {
  amplifier_.inject(mb::sim::Injection::exception, 2, mb::exception_code::illegal_data_address);
  auto d = request(write_and_read(100, 50));
  EXPECT_EQ(d.kind, Decision::Kind::exception);
  EXPECT_EQ(d.exception_code, mb::exception_code::illegal_data_address);
  EXPECT_EQ(request(write_and_read(100, 50)).kind, Decision::Kind::exception);
  EXPECT_EQ(request(write_and_read(100, 50)).kind, Decision::Kind::reply);  // count used up
  EXPECT_EQ(amplifier_.state().steps, 1u);                                  // refused requests apply nothing

  amplifier_.inject(mb::sim::Injection::timeout);
  EXPECT_EQ(request(write_and_read(100, 50)).kind, Decision::Kind::silence);
  EXPECT_EQ(amplifier_.state().steps, 1u);  // a lost request applies nothing

  amplifier_.inject(mb::sim::Injection::crc_error);
  EXPECT_EQ(request(write_and_read(100, 50)).kind, Decision::Kind::corrupt_crc);
  EXPECT_EQ(amplifier_.state().steps, 2u);  // applied; only the reply is corrupted

  amplifier_.inject(mb::sim::Injection::drop);
  EXPECT_EQ(request(write_and_read(100, 50)).kind, Decision::Kind::drop);
}

TEST_F(AmplifierTest, AnAmplifierWithoutFunction23AnswersIllegalFunction) {
  auto s = settings(config_);
  s.function_23 = false;
  mb::sim::Amplifier old(s, plant_);
  old.bind(holding_, input_, coils_);
  const auto d = old.on_request(write_and_read(100, 50), 0.0);
  EXPECT_EQ(d.kind, Decision::Kind::exception);
  EXPECT_EQ(d.exception_code, mb::exception_code::illegal_function);
}

}  // namespace amplifier_test
