// The simulated amplifier's command line (hapticd-devsim modbus, stdin).
#include <gtest/gtest.h>

#include "drivers/modbus/modbus_config.hpp"
#include "loopback_plant.hpp"
#include "sim/modbus/peer_commands.hpp"

namespace peer_commands_test {

namespace mb = hapticd::drivers::modbus;

namespace {
struct Peer {
  Peer() : config(mb::modbus_config({})), amplifier(settings(config), plant) {
    tcp = mb::sim::AmplifierServer::tcp(amplifier);
  }
  static mb::sim::AmplifierSettings settings(const mb::ModbusConfig& c) {
    mb::sim::AmplifierSettings s;
    s.position_per_count = c.position_per_count();
    return s;
  }
  std::string run(const std::string& line) { return mb::sim::run_peer_command(line, *tcp, amplifier); }
  mb::ModbusConfig config;
  mb::testing::LoopbackPlant plant;
  mb::sim::Amplifier amplifier;
  std::unique_ptr<mb::sim::AmplifierServer> tcp;
};
}  // namespace

TEST(ModbusPeerCommands, InjectionsAndState) {
  Peer p;
  EXPECT_EQ(p.run("exception 0x02 3"), "ok");
  EXPECT_EQ(p.run("timeout"), "ok");
  EXPECT_EQ(p.run("late 20 2"), "ok");
  EXPECT_EQ(p.run("drop"), "ok");
  EXPECT_EQ(p.run("fault 1"), "ok");
  p.amplifier.tick(0.0);
  EXPECT_EQ(p.run("state"),
            "ok {\"enabled\":false,\"fault\":1,\"torque\":0,\"torque_counts\":0,\"steps\":0,\"requests\":0,"
            "\"watchdog_armed\":false,\"watchdog_trips\":0,\"resets\":0,\"trip_silence_s\":0.000000,"
            "\"watchdog_register\":0,\"alive_jumps\":0}");
}

TEST(ModbusPeerCommands, BadCommandsSayWhatIsAccepted) {
  Peer p;
  EXPECT_EQ(p.run("crc"), "error: a CRC error needs RTU: Modbus TCP frames carry no CRC");
  EXPECT_EQ(p.run("exception 300"), "error: CODE \"300\" is not a whole number in 1..255");
  EXPECT_EQ(p.run("timeout -1"), "error: COUNT \"-1\" is not a whole number in 1..1000000");
  EXPECT_EQ(p.run("explode").rfind("error: \"explode\" is not a command; commands: exception CODE", 0), 0u);
  EXPECT_EQ(p.run("").rfind("error: empty command", 0), 0u);
}

}  // namespace peer_commands_test
