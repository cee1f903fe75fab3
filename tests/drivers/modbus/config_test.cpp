// [device.modbus] parameters: every refusal names the key and what is accepted.
#include <gtest/gtest.h>

#include <string>

#include <toml++/toml.h>

#include "drivers/modbus/modbus_config.hpp"

namespace config_test {

namespace mb = hapticd::drivers::modbus;
using Values = std::map<std::string, hapticd::drivers::ParameterValue, std::less<>>;

namespace {
// The key a refusal blames, and its message, or "" when accepted.
std::pair<std::string, std::string> refusal(const Values& values) {
  try {
    mb::modbus_config(values);
    return {"", ""};
  } catch (const hapticd::drivers::ParameterError& e) {
    return {e.key(), e.what()};
  }
}
}  // namespace

TEST(ModbusConfig, DefaultsDescribeTheSimulatedAmplifiersMap) {
  const mb::ModbusConfig c = mb::modbus_config({});
  EXPECT_EQ(c.transport, mb::Transport::tcp);
  EXPECT_EQ(c.serial.parity, mb::Parity::even);  // Modbus over Serial Line 2.5.1: even is the default
  EXPECT_EQ(c.serial.data_bits, 8);
  EXPECT_EQ(c.slave_id, 1);
  EXPECT_TRUE(c.function_23);
  EXPECT_EQ(c.transactions(), 1);
  EXPECT_EQ(c.map.torque, 10);
  ASSERT_TRUE(c.map.watchdog.has_value());
  EXPECT_EQ(*c.map.watchdog, 11);
  EXPECT_EQ(c.map.enable, mb::EnableKind::register_bit);
  EXPECT_EQ(c.map.fault_bits.size(), 5u);
  EXPECT_NEAR(c.position_per_count(), 2.0 * 3.14159265358979 / 16384.0, 1e-12);
}

TEST(ModbusConfig, TypedValuesAreApplied) {
  const mb::ModbusConfig c = mb::modbus_config({{"transport", std::string("rtu")},
                                                {"device", std::string("/dev/ttyS1")},
                                                {"baud", 19200.0},
                                                {"parity", std::string("none")},
                                                {"stop_bits", 2.0},
                                                {"word_order", std::string("low-first")},
                                                {"velocity_register", -1.0},
                                                {"direction", std::string("reversed")},
                                                {"function_23", false}});
  EXPECT_EQ(c.transport, mb::Transport::rtu);
  EXPECT_EQ(c.serial.baud, 19200);
  EXPECT_EQ(c.serial.parity, mb::Parity::none);
  EXPECT_EQ(c.serial.stop_bits, 2);
  EXPECT_EQ(c.map.word_order, mb::WordOrder::low_first);
  EXPECT_FALSE(c.map.velocity.has_value());
  EXPECT_EQ(c.direction, -1);
  EXPECT_EQ(c.transactions(), 2);
}

TEST(ModbusConfig, UnknownKeyListsTheAcceptedOnes) {
  const auto [key, message] = refusal({{"baudrate", 9600.0}});
  EXPECT_EQ(key, "baudrate");
  EXPECT_NE(message.find(
                "is not a parameter of the modbus driver; accepted: motion, mass, damping, transport, host"),
            std::string::npos)
      << message;
}

TEST(ModbusConfig, BaudRatesLibmodbusWouldTurnInto9600AreRefused) {
  const auto [key, message] = refusal({{"baud", 2000000.0}});
  EXPECT_EQ(key, "baud");
  EXPECT_NE(message.find("silently use 9600"), std::string::npos) << message;
  EXPECT_NE(message.find("1500000, 2500000"), std::string::npos) << message;
  EXPECT_EQ(refusal({{"baud", 4000000.0}}).first, "");
}

TEST(ModbusConfig, RangesTypesAndChoicesAreChecked) {
  EXPECT_EQ(refusal({{"port", 70000.0}}).first, "port");
  EXPECT_NE(refusal({{"port", 70000.0}}).second.find("accepted: a whole number in [1, 65535]"),
            std::string::npos);
  EXPECT_EQ(refusal({{"port", std::string("five hundred")}}).first, "port");
  EXPECT_EQ(refusal({{"slave_id", 1.5}}).first, "slave_id");
  EXPECT_EQ(refusal({{"parity", std::string("mark")}}).first, "parity");
  EXPECT_NE(refusal({{"parity", std::string("mark")}}).second.find("accepted: one of none, even, odd"),
            std::string::npos);
  EXPECT_EQ(refusal({{"data_bits", 7.0}}).first, "data_bits");
  EXPECT_EQ(refusal({{"rs485", 1.0}}).first, "rs485");
  EXPECT_EQ(refusal({{"link_budget", 1.0}}).first, "link_budget");
}

TEST(ModbusConfig, SlaveIdFollowsTheTransport) {
  // 248..254 are reserved; 255 is the Modbus TCP "no gateway" unit id.
  EXPECT_EQ(refusal({{"slave_id", 248.0}}).first, "slave_id");
  EXPECT_EQ(refusal({{"slave_id", 255.0}}).first, "");
  EXPECT_EQ(refusal({{"slave_id", 255.0}, {"transport", std::string("rtu")}}).first, "slave_id");
}

TEST(ModbusConfig, Function23NeedsHoldingRegisters) {
  const auto [key, message] = refusal({{"read_table", std::string("input")}});
  EXPECT_EQ(key, "function_23");
  EXPECT_NE(message.find("function_23 = false"), std::string::npos) << message;
  EXPECT_EQ(refusal({{"read_table", std::string("input")}, {"function_23", false}}).first, "");
}

TEST(ModbusConfig, MapConflictsNameTheKey) {
  EXPECT_EQ(refusal({{"watchdog_register", 30.0}}).first, "watchdog_register");
  EXPECT_EQ(refusal({{"watchdog_register", 30.0}, {"watchdog_refresh", std::string("any-frame")}}).first, "");
  EXPECT_EQ(refusal({{"torque_register", 4.0}, {"watchdog_register", -1.0}}).first, "torque_register");
  EXPECT_EQ(refusal({{"status_register", 1.0}}).first, "status_register");
  EXPECT_EQ(refusal({{"status_register", -1.0}}).first, "status_enabled_bit");
  EXPECT_EQ(refusal({{"status_fault_bit", 0.0}}).first, "status_fault_bit");
  EXPECT_EQ(refusal({{"fault_bits", std::string("x:y")}}).first, "fault_bits");
}

TEST(ModbusConfig, EveryParameterHasHelpAndAUsableDefault) {
  for (const auto& p : mb::modbus_parameters()) {
    EXPECT_FALSE(p.help.empty()) << p.name;
    ASSERT_TRUE(p.default_value.has_value()) << p.name;
    EXPECT_EQ(refusal({{p.name, *p.default_value}}).first, "") << p.name;
  }
}

// The shipped example must stay a valid [device.modbus] table.
TEST(ModbusConfig, TheShippedExampleIsValid) {
  const toml::table file = toml::parse_file(HAPTICD_SOURCE_DIR "/config/modbus.toml");
  const toml::table* table = file["device"]["modbus"].as_table();
  ASSERT_NE(table, nullptr);
  Values values;
  for (const auto& [key, node] : *table) {
    if (const auto* b = node.as_boolean())
      values.emplace(std::string(key.str()), b->get());
    else if (const auto* i = node.as_integer())
      values.emplace(std::string(key.str()), static_cast<double>(i->get()));
    else if (const auto* f = node.as_floating_point())
      values.emplace(std::string(key.str()), f->get());
    else if (const auto* s = node.as_string())
      values.emplace(std::string(key.str()), s->get());
  }
  EXPECT_EQ(values.size(), table->size());
  EXPECT_EQ(refusal(values).second, "");
}

}  // namespace config_test
