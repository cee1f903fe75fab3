// The register map: 32-bit word order, the periodic blocks, status and fault bits.
#include <gtest/gtest.h>

#include <array>
#include <limits>

#include "drivers/modbus/modbus_config.hpp"
#include "drivers/modbus/register_map.hpp"

namespace register_map_test {

namespace mb = hapticd::drivers::modbus;

TEST(ModbusRegisterMap, WordOrderSplitsAndJoins) {
  std::uint16_t a = 0, b = 0;
  mb::split_words(0x12345678, mb::WordOrder::high_first, a, b);
  EXPECT_EQ(a, 0x1234);
  EXPECT_EQ(b, 0x5678);
  mb::split_words(0x12345678, mb::WordOrder::low_first, a, b);
  EXPECT_EQ(a, 0x5678);
  EXPECT_EQ(b, 0x1234);
  // -2 = 0xFFFFFFFE: signed 32-bit across two registers.
  mb::split_words(-2, mb::WordOrder::high_first, a, b);
  EXPECT_EQ(a, 0xFFFF);
  EXPECT_EQ(b, 0xFFFE);
  EXPECT_EQ(mb::join_words(0xFFFF, 0xFFFE, mb::WordOrder::high_first), -2);
  EXPECT_EQ(mb::join_words(0xFFFE, 0xFFFF, mb::WordOrder::low_first), -2);
  EXPECT_EQ(mb::join_words(0x8000, 0x0000, mb::WordOrder::high_first),
            std::numeric_limits<std::int32_t>::min());
  EXPECT_EQ(mb::join_words(0x0001, 0x0000, mb::WordOrder::low_first), 1);
  EXPECT_EQ(mb::join_words(0x0001, 0x0000, mb::WordOrder::high_first), 65536);
}

TEST(ModbusRegisterMap, DefaultMapBlocks) {
  const mb::ModbusConfig c = mb::modbus_config({});
  const mb::LayoutResult r = mb::plan_blocks(c.map);
  ASSERT_EQ(r.error_key, "") << r.error;
  // torque 10, watchdog 11: one write block of 2; position 0-1, velocity 2-3, status 4, fault 5.
  EXPECT_EQ(r.layout.write_address, 10);
  EXPECT_EQ(r.layout.write_count, 2);
  EXPECT_EQ(r.layout.torque_index, 0);
  EXPECT_EQ(r.layout.watchdog_index, 1);
  EXPECT_EQ(r.layout.read_address, 0);
  EXPECT_EQ(r.layout.read_count, 6);
  EXPECT_EQ(r.layout.position_index, 0);
  EXPECT_EQ(r.layout.velocity_index, 2);
  EXPECT_EQ(r.layout.status_index, 4);
  EXPECT_EQ(r.layout.fault_index, 5);
}

TEST(ModbusRegisterMap, WatchdogBeforeTorqueLeadsTheBlock) {
  mb::RegisterMap m;
  m.torque = 21;
  m.watchdog = 20;
  const auto r = mb::plan_blocks(m);
  ASSERT_EQ(r.error_key, "");
  EXPECT_EQ(r.layout.write_address, 20);
  EXPECT_EQ(r.layout.watchdog_index, 0);
  EXPECT_EQ(r.layout.torque_index, 1);
  std::array<std::uint16_t, 2> block{};
  mb::encode_command(r.layout, -5, 50, block);
  EXPECT_EQ(block[0], 50);
  EXPECT_EQ(block[1], 0xFFFB);
}

TEST(ModbusRegisterMap, ANonAdjacentWatchdogIsRefusedUnlessRefreshedByAnyFrame) {
  mb::RegisterMap m;
  m.torque = 10;
  m.watchdog = 40;
  const auto r = mb::plan_blocks(m);
  EXPECT_EQ(r.error_key, "watchdog_register");
  EXPECT_NE(r.error.find("9 or 11"), std::string::npos) << r.error;
  m.watchdog_refresh = mb::WatchdogRefresh::any_frame;
  const auto ok = mb::plan_blocks(m);
  EXPECT_EQ(ok.error_key, "");
  EXPECT_EQ(ok.layout.write_count, 1);
  EXPECT_EQ(ok.layout.watchdog_index, -1);
}

TEST(ModbusRegisterMap, OverlapsAndWideSpansAreRefused) {
  mb::RegisterMap m;
  m.position = 0;
  m.status = 1;  // inside the 32-bit position
  auto r = mb::plan_blocks(m);
  EXPECT_EQ(r.error_key, "status_register");
  EXPECT_NE(r.error.find("overlaps position_register"), std::string::npos) << r.error;
  m.status = 200;  // 0..200 = 201 registers > 125
  r = mb::plan_blocks(m);
  EXPECT_EQ(r.error_key, "status_register");
  EXPECT_NE(r.error.find("201 registers"), std::string::npos) << r.error;
  m.status = 124;  // 0..124 = 125 registers: one request
  EXPECT_EQ(mb::plan_blocks(m).error_key, "");
}

TEST(ModbusRegisterMap, DecodeSampleReadsStatusAndFaultBits) {
  mb::RegisterMap m;
  m.position = 0;
  m.word_order = mb::WordOrder::low_first;
  m.velocity = 2;
  m.status = 4;
  m.status_enabled_bit = 0;
  m.status_fault_bit = 3;
  m.fault = 5;
  const auto r = mb::plan_blocks(m);
  ASSERT_EQ(r.error_key, "");
  std::array<std::uint16_t, 6> block{};
  mb::split_words(-123456, m.word_order, block[0], block[1]);
  mb::split_words(7000, m.word_order, block[2], block[3]);
  block[4] = 0x0001;
  block[5] = 0;
  auto s = mb::decode_sample(m, r.layout, block);
  EXPECT_EQ(s.position_counts, -123456);
  EXPECT_EQ(s.velocity_counts, 7000);
  EXPECT_TRUE(s.enabled);
  EXPECT_FALSE(s.faulted);
  block[4] = 0x0008;  // fault bit, power stage off
  s = mb::decode_sample(m, r.layout, block);
  EXPECT_FALSE(s.enabled);
  EXPECT_TRUE(s.faulted);
  block[4] = 0x0001;
  block[5] = 0x0004;  // a fault word alone is a fault
  s = mb::decode_sample(m, r.layout, block);
  EXPECT_TRUE(s.faulted);
  EXPECT_EQ(s.fault, 0x0004);
}

TEST(ModbusRegisterMap, TorqueCountsRoundAndSaturate) {
  bool saturated = true;
  EXPECT_EQ(mb::torque_counts(0.8, 0.001, saturated), 800);
  EXPECT_FALSE(saturated);
  EXPECT_EQ(mb::torque_counts(-0.0004, 0.001, saturated), 0);  // rounds to nearest
  EXPECT_EQ(mb::torque_counts(-0.0006, 0.001, saturated), -1);
  EXPECT_EQ(mb::torque_counts(40.0, 0.001, saturated), 32767);  // int16 command
  EXPECT_TRUE(saturated);
  EXPECT_EQ(mb::torque_counts(-40.0, 0.001, saturated), -32768);
  EXPECT_TRUE(saturated);
}

TEST(ModbusRegisterMap, FaultWordInWords) {
  const auto bits = mb::parse_fault_bits("0:over-current, 2:watchdog");
  ASSERT_EQ(bits.size(), 2u);
  EXPECT_EQ(mb::describe_faults(0x0085, bits), "over-current, watchdog, bit 7 (fault register 0x0085)");
  EXPECT_EQ(mb::format_fault_bits(bits), "0:over-current,2:watchdog");
  EXPECT_THROW(mb::parse_fault_bits("16:too-high"), std::invalid_argument);
  EXPECT_THROW(mb::parse_fault_bits("over-current"), std::invalid_argument);
  EXPECT_THROW(mb::parse_fault_bits("1:a,1:b"), std::invalid_argument);
  EXPECT_TRUE(mb::parse_fault_bits("").empty());
}

}  // namespace register_map_test
