#include "daemon/config/config.hpp"
#include "drivers/registry.hpp"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

namespace hapticd::daemon::config::config_test {
namespace {

/// Parses text as file "t.toml" and returns the ConfigError's what(), or
/// "no error".
std::string error_of(std::string_view text) {
  try {
    parse_config(text, "t.toml");
  } catch (const ConfigError& error) {
    return error.what();
  }
  return "no error";
}

TEST(ConfigDefaults, EmptyFileGivesStructDefaults) {
  const DaemonConfig config = parse_config("", "empty.toml");
  EXPECT_EQ(config.source, "empty.toml");
  EXPECT_DOUBLE_EQ(config.loop.period_s, 1e-3);
  EXPECT_EQ(config.loop.priority, 80);
  EXPECT_EQ(config.loop.cpu, -1);
  EXPECT_FALSE(config.loop.require_rt);
  EXPECT_EQ(config.loop.clock, ClockKind::real);
  EXPECT_EQ(config.loop.overrun_limit, 10u);
  EXPECT_FALSE(config.loop.duration_s.has_value());
  EXPECT_EQ(config.device.driver, "loopback");
  EXPECT_DOUBLE_EQ(config.device.torque_limit, 1.0);
  EXPECT_FALSE(config.device.max_velocity.has_value()) << "derived from the device";
  EXPECT_TRUE(config.device.parameters.empty());
  EXPECT_EQ(config.scene.name, "spring-wheel");
  EXPECT_TRUE(config.scene.parameters.empty());
  EXPECT_EQ(config.control.socket, "");
  EXPECT_EQ(config.control.group, "");
  EXPECT_EQ(config.control.max_clients, 16u);
  EXPECT_EQ(config.control.max_message_bytes, 65536u);
  EXPECT_DOUBLE_EQ(config.control.idle_timeout_s, 300.0);
  EXPECT_EQ(config.recorder.directory, "");
  EXPECT_DOUBLE_EQ(config.recorder.ring_seconds, 2.0);
  EXPECT_DOUBLE_EQ(config.recorder.flush_interval_s, 0.1);
  EXPECT_EQ(config.control.cpu, -1);
  EXPECT_EQ(config.recorder.cpu, -1);
}

TEST(ConfigDefaults, BuiltInDefaultIsLoopbackWheelWithExactIntegrator) {
  const DaemonConfig config = default_config();
  EXPECT_EQ(config.source, "<built-in default>");
  EXPECT_EQ(config.device.driver, "loopback");
  // A rotary wheel with the driver's own defaults: the built-in default
  // restates none of them, so a file that leaves them out gets the same
  // device (MinimalConfig tests in default_equivalence_test.cpp).
  ASSERT_EQ(config.device.parameters.size(), 1u);
  EXPECT_EQ(config.device.parameters[0].key, "motion");
  EXPECT_EQ(config.device.parameters[0].value, ParameterValue{std::string("rotary")});
  EXPECT_EQ(config.scene.name, "spring-wheel");
  ASSERT_EQ(config.scene.parameters.size(), 1u);
  EXPECT_EQ(config.scene.parameters[0].key, "integrator");
  EXPECT_EQ(config.scene.parameters[0].value, ParameterValue{std::string("exact")});
  EXPECT_EQ(config.scene.parameters[0].where.to_string(), "<built-in default>:22:14");
  EXPECT_DOUBLE_EQ(config.loop.period_s, 1e-3);
  EXPECT_EQ(config.recorder.ring_capacity(config.loop.period_s), 2000u);
}

void strip_positions(DaemonConfig& config) {
  config.source.clear();
  config.device.driver_where = {};
  config.device.table_where = {};
  config.device.origin_where = config.device.origin_file_where = {};
  config.scene.name_where = {};
  config.scene.table_where = {};
  config.control.socket_where = {};
  config.control.group_where = {};
  config.recorder.directory_where = {};
  config.telemetry.udp_where = config.telemetry.channels_where = {};
  config.telemetry.channel_where.clear();
  for (auto& p : config.device.parameters) p.where = {};
  for (auto& p : config.scene.parameters) p.where = {};
}

TEST(ConfigDefaults, InstalledHapticdTomlEqualsBuiltInDefault) {
  DaemonConfig shipped = load_config(std::filesystem::path(HAPTICD_SOURCE_DIR) / "config" / "hapticd.toml");
  DaemonConfig builtin = default_config();
  strip_positions(shipped);
  strip_positions(builtin);
  EXPECT_EQ(shipped.loop, builtin.loop);
  EXPECT_EQ(shipped.device, builtin.device);
  EXPECT_EQ(shipped.scene, builtin.scene);
  EXPECT_EQ(shipped.control, builtin.control);
  EXPECT_EQ(shipped.recorder, builtin.recorder);
  EXPECT_EQ(shipped.telemetry, builtin.telemetry);
}

TEST(ConfigValues, AllKeysParse) {
  const DaemonConfig config = parse_config(R"(
[loop]
period = "250us"
priority = 95
cpu = 1
require_rt = true
clock = "virtual"
overrun_limit = 0
duration = "10s"
[device]
torque_limit = 2.5
driver = "loopback"
[device.loopback]
plant = "two-mass"
cable_stiffness = 79.5e3
quantize = false
[device.loopback.hand]
kind = "sine"
[scene]
K = 9000
name = "wall"
B = 4.6
[control]
socket = "/run/hapticd/control.sock"
group = "haptics"
max_clients = 4
max_message_bytes = 4096
idle_timeout = 0
cpu = 0
[recorder]
directory = "/tmp/rec"
ring_seconds = 0.5
flush_interval = 0.25
cpu = 0
)",
                                           "all.toml");
  EXPECT_DOUBLE_EQ(config.loop.period_s, 250e-6);
  EXPECT_EQ(config.loop.priority, 95);
  EXPECT_EQ(config.loop.cpu, 1);
  EXPECT_TRUE(config.loop.require_rt);
  EXPECT_EQ(config.loop.clock, ClockKind::virtual_clock);
  EXPECT_EQ(config.loop.overrun_limit, 0u);
  ASSERT_TRUE(config.loop.duration_s.has_value());
  EXPECT_DOUBLE_EQ(*config.loop.duration_s, 10.0);
  EXPECT_DOUBLE_EQ(config.device.torque_limit, 2.5);
  EXPECT_EQ(config.device.driver_where.to_string(), "all.toml:12:10");
  ASSERT_EQ(config.device.parameters.size(), 4u);
  EXPECT_EQ(config.device.parameters[0].key, "plant");
  EXPECT_EQ(config.device.parameters[1].key, "cable_stiffness");
  EXPECT_EQ(config.device.parameters[1].value, ParameterValue{79.5e3});
  EXPECT_EQ(config.device.parameters[1].where.to_string(), "all.toml:15:19");
  EXPECT_EQ(config.device.parameters[2].value, ParameterValue{false});
  EXPECT_EQ(config.device.parameters[3].key, "hand.kind");
  EXPECT_EQ(config.device.parameters[3].where.line, 18u);
  EXPECT_EQ(config.scene.name, "wall");
  EXPECT_EQ(config.scene.name_where.line, 21u);
  // File order, not key order; integers become doubles; name is not a parameter.
  ASSERT_EQ(config.scene.parameters.size(), 2u);
  EXPECT_EQ(config.scene.parameters[0].key, "K");
  EXPECT_EQ(config.scene.parameters[0].value, ParameterValue{9000.0});
  EXPECT_EQ(config.scene.parameters[0].where.to_string(), "all.toml:20:5");
  EXPECT_EQ(config.scene.parameters[1].key, "B");
  EXPECT_EQ(config.control.socket, "/run/hapticd/control.sock");
  EXPECT_EQ(config.control.group, "haptics");
  EXPECT_EQ(config.control.max_clients, 4u);
  EXPECT_EQ(config.control.max_message_bytes, 4096u);
  EXPECT_DOUBLE_EQ(config.control.idle_timeout_s, 0.0);
  EXPECT_EQ(config.control.cpu, 0);
  EXPECT_EQ(config.recorder.directory, "/tmp/rec");
  EXPECT_EQ(config.recorder.cpu, 0);
  EXPECT_DOUBLE_EQ(config.recorder.ring_seconds, 0.5);
  EXPECT_DOUBLE_EQ(config.recorder.flush_interval_s, 0.25);
  EXPECT_EQ(config.recorder.ring_capacity(config.loop.period_s), 2000u);
}

// The positions errors found after parsing (host checks, the driver, the
// scene catalog) are reported at.
TEST(ConfigPositions, KeysAndTablesKeepTheirPositions) {
  const DaemonConfig config = parse_config(R"([control]
socket = "/run/x.sock"
  group = "haptics"
[recorder]
directory = "/tmp/rec"
[device.loopback]
mass = 0.2
[scene]
stiffness = 3
)",
                                           "p.toml");
  EXPECT_EQ(config.control.socket_where.to_string(), "p.toml:2:10");
  EXPECT_EQ(config.control.group_where.to_string(), "p.toml:3:11");
  EXPECT_EQ(config.recorder.directory_where.to_string(), "p.toml:5:13");
  EXPECT_EQ(config.device.table_where.to_string(), "p.toml:6:9");
  EXPECT_EQ(config.device.driver_where.to_string(), "p.toml:6:2");  // no driver key: the [device...] header
  EXPECT_EQ(config.scene.table_where.to_string(), "p.toml:8:2");
  EXPECT_EQ(config.scene.name_where.to_string(), "p.toml:8:2");  // no name key: the [scene] header
  // What the file leaves out is blamed on the file.
  const DaemonConfig empty = parse_config("", "e.toml");
  EXPECT_EQ(empty.control.socket_where.to_string(), "e.toml");
  EXPECT_EQ(empty.recorder.directory_where.to_string(), "e.toml");
  EXPECT_EQ(empty.device.table_where.to_string(), "e.toml");
  EXPECT_EQ(empty.scene.name_where.to_string(), "e.toml");
}

TEST(ConfigDurations, SuffixesNumbersAndRangeEdges) {
  EXPECT_DOUBLE_EQ(parse_config("[loop]\nperiod = \"100us\"", "t").loop.period_s, 100e-6);
  EXPECT_DOUBLE_EQ(parse_config("[loop]\nperiod = \"10ms\"", "t").loop.period_s, 10e-3);
  EXPECT_DOUBLE_EQ(parse_config("[loop]\nperiod = \"0.002s\"", "t").loop.period_s, 2e-3);
  EXPECT_DOUBLE_EQ(parse_config("[loop]\nperiod = \"0.0005\"", "t").loop.period_s, 5e-4);
  EXPECT_DOUBLE_EQ(parse_config("[loop]\nperiod = 0.001", "t").loop.period_s, 1e-3);
  EXPECT_DOUBLE_EQ(parse_config("[control]\nidle_timeout = 60", "t").control.idle_timeout_s, 60.0);
  EXPECT_DOUBLE_EQ(*parse_config("[loop]\nduration = \"1.5s\"", "t").loop.duration_s, 1.5);
  EXPECT_FALSE(parse_config("[loop]\nduration = \"\"", "t").loop.duration_s.has_value());
  EXPECT_EQ(error_of("[loop]\nperiod = \"99us\""),
            "t.toml:2:10: loop.period = \"99us\" is out of range; accepted: 100us to 10ms");
  EXPECT_EQ(error_of("[loop]\nperiod = \"11ms\""),
            "t.toml:2:10: loop.period = \"11ms\" is out of range; accepted: 100us to 10ms");
  EXPECT_EQ(error_of("[loop]\nperiod = 1"),
            "t.toml:2:10: loop.period = 1 is out of range; accepted: 100us to 10ms");
  EXPECT_EQ(error_of("[loop]\nperiod = \"1 kHz\""),
            "t.toml:2:10: loop.period = \"1 kHz\" is not a duration; accepted: 100us to 10ms (a string with "
            "suffix s, ms or us, or a number of seconds)");
  EXPECT_EQ(error_of("[loop]\nduration = \"0s\""),
            "t.toml:2:12: loop.duration = \"0s\" is out of range; accepted: \"\" (run until signalled) or "
            "more than 0s");
  EXPECT_EQ(error_of("[recorder]\nflush_interval = \"20s\""),
            "t.toml:2:18: recorder.flush_interval = \"20s\" is out of range; accepted: 1ms to 10s");
  EXPECT_EQ(error_of("[control]\nidle_timeout = \"-1s\""),
            "t.toml:2:16: control.idle_timeout = \"-1s\" is out of range; accepted: 0s (never) to 86400s");
}

TEST(ConfigErrors, OutOfRangeExampleFromTheBrief) {
  const std::string text = "# hapticd\n\n[loop]\nperiod = \"5s\"\n";
  try {
    parse_config(text, "/etc/hapticd/hapticd.toml");
    FAIL() << "no error";
  } catch (const ConfigError& error) {
    EXPECT_STREQ(
        error.what(),
        "/etc/hapticd/hapticd.toml:4:10: loop.period = \"5s\" is out of range; accepted: 100us to 10ms");
    EXPECT_EQ(error.key(), "loop.period");
    EXPECT_EQ(error.where().line, 4u);
    EXPECT_EQ(error.where().column, 10u);
  }
}

TEST(ConfigErrors, UnknownKeysNameSectionAndAcceptedKeys) {
  EXPECT_EQ(error_of("[loop]\nperiod = \"1ms\"\nperod = \"1ms\""),
            "t.toml:3:1: unknown key 'perod' in [loop]; accepted: period, priority, cpu, require_rt, clock, "
            "overrun_limit, duration");
  EXPECT_EQ(error_of("[control]\n  maxclients = 3"),
            "t.toml:2:3: unknown key 'maxclients' in [control]; accepted: socket, group, max_clients, "
            "max_message_bytes, idle_timeout, cpu");
  EXPECT_EQ(
      error_of("[recorder]\ndir = \"x\""),
      "t.toml:2:1: unknown key 'dir' in [recorder]; accepted: directory, ring_seconds, flush_interval, cpu");
  EXPECT_EQ(error_of("[device]\nlimit = 1"),
            "t.toml:2:1: unknown key 'limit' in [device]; accepted: driver, torque_limit, axis_torque_limit, "
            "max_velocity, "
            "model, axis_names, kinematics, encoder, origin, origin_file, require_calibration, and a table "
            "[device.<driver>] for the selected driver");
  EXPECT_EQ(error_of("[device.serial]\nx = 1"),
            "t.toml:1:9: unknown key 'serial' in [device]; accepted: driver, torque_limit, "
            "axis_torque_limit, max_velocity, "
            "model, axis_names, kinematics, encoder, origin, origin_file, require_calibration, and a table "
            "[device.<driver>] for the selected driver");
}

TEST(ConfigErrors, AxisNamesAndKinematicsNameTheKeyAndWhatIsAccepted) {
  const std::string names =
      "an array of 1 to 6 distinct axis names of 1 to 16 letters, digits or _, e.g. [\"x\", \"y\"]";
  EXPECT_EQ(error_of("[device]\naxis_names = \"x,y\""),
            "t.toml:2:14: device.axis_names = \"x,y\" has the wrong type; accepted: " + names);
  EXPECT_EQ(error_of("[device]\naxis_names = []"),
            "t.toml:2:14: device.axis_names = [...] is out of range; accepted: " + names);
  EXPECT_EQ(error_of("[device]\naxis_names = [\"x\", \"x\"]"),
            "t.toml:2:20: device.axis_names = \"x\" is out of range; accepted: " + names);
  EXPECT_EQ(error_of("[device]\naxis_names = [\"x y\"]"),
            "t.toml:2:15: device.axis_names = \"x y\" is out of range; accepted: " + names);
  EXPECT_EQ(error_of("[device]\naxis_names = [\"a\",\"b\",\"c\",\"d\",\"e\",\"f\",\"g\"]"),
            "t.toml:2:14: device.axis_names = [...] is out of range; accepted: " + names);
  EXPECT_EQ(error_of("[device]\nkinematics = \"scara\""),
            "t.toml:2:14: device.kinematics = \"scara\" is out of range; accepted: \"cartesian\" or "
            "\"pantograph\"");
  // A pantograph only where a driver provides one (the loopback's linkage),
  // saying why not; and the loopback's linkage only with its kinematics.
  EXPECT_EQ(
      error_of("[device]\nkinematics = \"pantograph\""),
      "t.toml:2:14: device.kinematics = \"pantograph\" is not accepted here: the loopback simulates a "
      "pantograph only with [device.loopback] linkage = \"pantograph\"; accepted: \"cartesian\", or the "
      "loopback with [device.loopback] linkage = \"pantograph\"");
  EXPECT_EQ(error_of("[device]\ndriver = \"canopen\"\nkinematics = \"pantograph\"").substr(0, 125),
            "t.toml:3:14: device.kinematics = \"pantograph\" is not accepted here: the canopen driver cannot "
            "provide a pantograph: it drives");
  EXPECT_EQ(error_of("[device]\n[device.loopback]\nlinkage = \"pantograph\"").substr(0, 88),
            "t.toml:3:11: device.loopback.linkage = \"pantograph\" reads joint angles of a linkage; it ");
  const auto pantograph = parse_config(
      "[device]\nkinematics = \"pantograph\"\n[device.loopback]\nlinkage = \"pantograph\"", "t.toml");
  EXPECT_EQ(pantograph.device.kinematics, "pantograph");
  const auto config =
      parse_config("[device]\naxis_names = [\"left\", \"up_2\"]\nkinematics = \"cartesian\"", "t.toml");
  EXPECT_EQ(config.device.axis_names, (std::vector<std::string>{"left", "up_2"}));
  EXPECT_EQ(config.device.axis_names_where.line, 2U);
  EXPECT_EQ(config.device.kinematics, "cartesian");
  EXPECT_TRUE(default_config().device.axis_names.empty()) << "the default: named by the device's count";
}

TEST(ConfigValues, GravityAndWorkspaceParse) {
  const DaemonConfig config = parse_config(
      "[gravity]\naxis = \"y\"\nmass = 0.3\nacceleration = 1.62\ndown = \"positive\"\n"
      "[workspace]\nshape = \"box\"\nlow = \"-0.01,-0.01\"\nstiffness = 2000\n",
      "t.toml");
  EXPECT_TRUE(config.gravity.configured);
  EXPECT_EQ(config.gravity.axis, "y");
  EXPECT_EQ(config.gravity.mass, 0.3);
  EXPECT_EQ(config.gravity.acceleration, 1.62);
  EXPECT_TRUE(config.gravity.down_positive);
  EXPECT_EQ(config.gravity.mass_where, (SourcePosition{"t.toml", 3, 8}));
  EXPECT_EQ(config.workspace.shape, "box");
  ASSERT_EQ(config.workspace.parameters.size(), 2U);
  EXPECT_EQ(config.workspace.parameters[0].key, "low");
  EXPECT_EQ(config.workspace.parameters[1].value, ParameterValue(2000.0));
  const DaemonConfig links = parse_config(
      "[gravity]\nlink_masses = [0.02, 0.03, 0.03, 0.02]\nhandle_mass = 0.01\nacceleration = 9.8\n",
      "t.toml");
  EXPECT_EQ(links.gravity.link_masses, (std::vector<double>{0.02, 0.03, 0.03, 0.02}));
  EXPECT_EQ(links.gravity.handle_mass, 0.01);
  EXPECT_EQ(links.gravity.acceleration, 9.8);
  EXPECT_EQ(links.gravity.link_masses_where, (SourcePosition{"t.toml", 2, 15}));
  EXPECT_TRUE(links.gravity.axis.empty());
  const DaemonConfig none = parse_config("", "t.toml");
  EXPECT_FALSE(none.gravity.configured);
  EXPECT_TRUE(none.workspace.shape.empty());
}

TEST(ConfigErrors, GravityAndWorkspaceNameTheKeyAndWhatIsAccepted) {
  EXPECT_EQ(
      error_of("[gravity]\naxis = \"y\"\nmass = 0\n"),
      "t.toml:3:8: gravity.mass = 0 is out of range; accepted: a mass in kg greater than 0 and at most 100");
  EXPECT_EQ(error_of("[gravity]\naxis = \"y\"\nmass = inf\n").find("t.toml:3:8: gravity.mass = inf"), 0U);
  EXPECT_EQ(
      error_of("[gravity]\naxis = \"y\"\nmass = 1\ndown = \"up\"\n"),
      "t.toml:4:8: gravity.down = \"up\" is out of range; accepted: \"negative\" (the axis points up) or "
      "\"positive\"");
  EXPECT_EQ(error_of("[gravity]\naxis = \"y\"\n"),
            "t.toml:1:1: [gravity] needs mass (kg); accepted: mass (one vertical linear axis, or a stage's "
            "vertical axis named by axis; down), or link_masses (the pantograph in a vertical plane; "
            "handle_mass); acceleration with either");
  EXPECT_EQ(error_of("[gravity]\naxis = \"y\"\nmass = 1\nweight = 2\n"),
            "t.toml:4:1: unknown key 'weight' in [gravity]; accepted: axis, mass, down, link_masses, "
            "handle_mass, acceleration");
  EXPECT_EQ(
      error_of("[gravity]\nlink_masses = [0.1, -0.1, 0.1, 0.1]\n"),
      "t.toml:2:21: gravity.link_masses = -0.1 is out of range; accepted: four masses in kg from 0 to 10: "
      "[proximal left, distal left, distal right, proximal right]");
  EXPECT_EQ(
      error_of("[gravity]\nlink_masses = 0.1\n"),
      "t.toml:2:15: gravity.link_masses = 0.1 has the wrong type; accepted: four masses in kg from 0 to 10: "
      "[proximal left, distal left, distal right, proximal right]");
  EXPECT_EQ(error_of("[gravity]\nlink_masses = [0.1, 0.1, 0.1, 0.1]\nmass = 1\n"),
            "t.toml:3:8: [gravity] gives both a stage's axis, mass or down and the pantograph's link_masses; "
            "accepted: mass (one vertical linear axis, or a stage's vertical axis named by axis; down), or "
            "link_masses (the pantograph in a vertical plane; handle_mass); acceleration with either");
  EXPECT_EQ(error_of("[workspace]\nlow = \"0,0\"\n"),
            "t.toml:1:1: [workspace] needs shape; accepted: \"box\" or \"sphere\"");
  EXPECT_EQ(error_of("[workspace]\nshape = \"cube\"\n"),
            "t.toml:2:9: workspace.shape = \"cube\" is out of range; accepted: \"box\" or \"sphere\"");
}

TEST(ConfigErrors, UnknownSectionsAndTopLevelKeys) {
  EXPECT_EQ(
      error_of("[loop]\n\n[looop]\nperiod = 1"),
      "t.toml:3:2: unknown section [looop]; accepted: loop, device, scene, gravity, workspace, control, "
      "recorder, telemetry");
  EXPECT_EQ(error_of("period = \"1ms\""),
            "t.toml:1:1: unknown key 'period' outside any section; accepted sections: loop, device, scene, "
            "gravity, workspace, control, recorder, telemetry");
  EXPECT_EQ(error_of("loop = 3"), "t.toml:1:1: 'loop' must be a section [loop], not a value");
}

TEST(ConfigErrors, WrongTypesAndRanges) {
  EXPECT_EQ(error_of("[loop]\npriority = \"high\""),
            "t.toml:2:12: loop.priority = \"high\" has the wrong type; accepted: an integer from 1 to 99");
  EXPECT_EQ(error_of("[loop]\npriority = 100"),
            "t.toml:2:12: loop.priority = 100 is out of range; accepted: an integer from 1 to 99");
  EXPECT_EQ(error_of("[loop]\npriority = 80.0"),
            "t.toml:2:12: loop.priority = 80.0 has the wrong type; accepted: an integer from 1 to 99");
  EXPECT_EQ(
      error_of("[loop]\ncpu = -2"),
      "t.toml:2:7: loop.cpu = -2 is out of range; accepted: -1 (no pinning) or a CPU index from 0 to 1023");
  EXPECT_EQ(error_of("[control]\ncpu = 1024"),
            "t.toml:2:7: control.cpu = 1024 is out of range; accepted: -1 (no pinning) or a CPU index from 0 "
            "to 1023");
  EXPECT_EQ(error_of("[recorder]\ncpu = \"0\""),
            "t.toml:2:7: recorder.cpu = \"0\" has the wrong type; accepted: -1 (no pinning) or a CPU index "
            "from 0 to 1023");
  EXPECT_EQ(error_of("[loop]\nrequire_rt = 1"),
            "t.toml:2:14: loop.require_rt = 1 has the wrong type; accepted: true or false");
  EXPECT_EQ(error_of("[loop]\nclock = \"wall\""),
            "t.toml:2:9: loop.clock = \"wall\" is not a clock; accepted: \"real\" or \"virtual\"");
  EXPECT_EQ(
      error_of("[loop]\noverrun_limit = -1"),
      "t.toml:2:17: loop.overrun_limit = -1 is out of range; accepted: an integer from 0 (never) to 1000000");
  EXPECT_EQ(
      error_of("[device]\ntorque_limit = 0"),
      "t.toml:2:16: device.torque_limit = 0 is out of range; accepted: a number greater than 0 (N or N m)");
  EXPECT_EQ(
      error_of("[device]\ntorque_limit = nan"),
      "t.toml:2:16: device.torque_limit = nan is out of range; accepted: a number greater than 0 (N or N m)");
  EXPECT_EQ(error_of("[device]\ntorque_limit = \"1 N\""),
            "t.toml:2:16: device.torque_limit = \"1 N\" has the wrong type; accepted: a number greater than "
            "0 (N or N m)");
  // [device] max_velocity (issue 17): "" or a number > 0.
  EXPECT_EQ(error_of("[device]\nmax_velocity = 0"),
            "t.toml:2:16: device.max_velocity = 0 is out of range; accepted: \"\" (derived from the device: "
            "docs/config.md) or a number greater than 0 (m/s or rad/s)");
  EXPECT_EQ(
      error_of("[device]\nmax_velocity = -inf"),
      "t.toml:2:16: device.max_velocity = -inf is out of range; accepted: \"\" (derived from the device: "
      "docs/config.md) or a number greater than 0 (m/s or rad/s)");
  EXPECT_EQ(
      error_of("[device]\nmax_velocity = \"fast\""),
      "t.toml:2:16: device.max_velocity = \"fast\" has the wrong type; accepted: \"\" (derived from the "
      "device: docs/config.md) or a number greater than 0 (m/s or rad/s)");
  EXPECT_EQ(parse_config("[device]\nmax_velocity = 120\n", "t.toml").device.max_velocity, 120.0);
  EXPECT_FALSE(parse_config("[device]\nmax_velocity = \"\"\n", "t.toml").device.max_velocity.has_value());
  EXPECT_EQ(error_of("[control]\nmax_clients = 0"),
            "t.toml:2:15: control.max_clients = 0 is out of range; accepted: an integer from 1 to 1024");
  EXPECT_EQ(error_of("[control]\nmax_message_bytes = 100"),
            "t.toml:2:21: control.max_message_bytes = 100 is out of range; accepted: an integer from 1024 to "
            "16777216");
  EXPECT_EQ(error_of("[control]\nsocket = \"/" + std::string(107, 'x') + "\""),
            "t.toml:2:10: control.socket = \"/" + std::string(107, 'x') +
                "\" is out of range; accepted: \"\" (default path) or a path of at most 107 bytes");
  EXPECT_EQ(parse_config("[control]\nsocket = \"/" + std::string(106, 'x') + "\"", "t").control.socket.size(),
            107u);
  EXPECT_EQ(error_of("[recorder]\nring_seconds = 0.01"),
            "t.toml:2:16: recorder.ring_seconds = 0.01 is out of range; accepted: a number of seconds from "
            "0.1 to 60");
  EXPECT_EQ(error_of("[scene]\nname = \"\""),
            "t.toml:2:8: scene.name = \"\" is out of range; accepted: a non-empty scene name (spring-wheel, "
            "spring-mass, wall, relay, free, ...)");
}

TEST(ConfigErrors, DriversAndDriverTables) {
  EXPECT_EQ(error_of("[device]\ndriver = \"serial\""),
            "t.toml:2:10: device.driver = \"serial\" is not a known driver; accepted: " +
                hapticd::drivers::driver_names());  // the registry's names, in its order
  EXPECT_EQ(hapticd::drivers::driver_names().rfind("loopback, usb-hid, canopen, modbus, gpio-pwm", 0), 0U);
  // The table must match the selected driver, wherever driver is written.
  EXPECT_EQ(error_of("[device.canopen]\nnode_id = 5\n[device]\ndriver = \"loopback\""),
            "t.toml:1:9: [device.canopen] does not match device.driver = \"loopback\"; accepted: "
            "[device.loopback]");
  // Drivers not built yet still parse: the daemon refuses them, not the config.
  const DaemonConfig config =
      parse_config("[device]\ndriver = \"modbus\"\n[device.modbus]\nslave_id = 5\n", "t");
  EXPECT_EQ(config.device.driver, "modbus");
  ASSERT_EQ(config.device.parameters.size(), 1u);
  EXPECT_EQ(config.device.parameters[0].value, ParameterValue{5.0});
}

TEST(ConfigErrors, FreeFormValuesMustBeScalars) {
  EXPECT_EQ(error_of("[scene]\nk = [1, 2]"),
            "t.toml:2:5: scene.k = [...] has the wrong type; accepted: a number, a boolean or a string");
  EXPECT_EQ(
      error_of("[device.loopback]\nhand.start = 1979-05-27"),
      "t.toml:2:14: device.loopback.hand.start = (a date/time) has the wrong type; accepted: a number, a "
      "boolean or a string");
  EXPECT_EQ(error_of("[scene]\nk = inf"),
            "t.toml:2:5: scene.k = inf is out of range; accepted: a finite number, a boolean or a string");
}

TEST(ConfigErrors, SyntaxErrorsCarryTomlPosition) {
  const std::string message = error_of("[loop]\npriority = 80\nperiod = \"1ms\n");
  EXPECT_EQ(message.rfind("t.toml:3:", 0), 0u) << message;
  EXPECT_NE(message.find("TOML syntax error: "), std::string::npos) << message;
  const std::string duplicate = error_of("[loop]\npriority = 80\npriority = 81\n");
  EXPECT_EQ(duplicate.rfind("t.toml:3:", 0), 0u) << duplicate;
}

TEST(ConfigErrors, MissingFile) {
  try {
    load_config("/nonexistent/hapticd.toml");
    FAIL() << "no error";
  } catch (const ConfigError& error) {
    EXPECT_STREQ(error.what(), "/nonexistent/hapticd.toml: cannot read the configuration file");
  }
}

TEST(ConfigHelpers, FormatErrorAndToToml) {
  EXPECT_EQ(format_error({"f.toml", 3, 7}, "scene.k: unknown"), "f.toml:3:7: scene.k: unknown");
  EXPECT_EQ(format_error({"f.toml", 0, 0}, "x"), "f.toml: x");
  EXPECT_EQ(format_error({}, "x"), "x");
  EXPECT_EQ(to_toml(ParameterValue{1.5}), "1.5");
  EXPECT_EQ(to_toml(ParameterValue{2.0}), "2.0");
  EXPECT_EQ(to_toml(ParameterValue{true}), "true");
  EXPECT_EQ(to_toml(ParameterValue{std::string("a\"b")}), "\"a\\\"b\"");
}

TEST(ConfigHelpers, RecordingDirectoryResolution) {
  RecorderConfig recorder;
  EXPECT_EQ(resolve_recording_directory(recorder, nullptr), std::filesystem::path("."));
  EXPECT_EQ(resolve_recording_directory(recorder, ""), std::filesystem::path("."));
  EXPECT_EQ(resolve_recording_directory(recorder, "/var/lib/hapticd"),
            std::filesystem::path("/var/lib/hapticd/recordings"));
  EXPECT_EQ(resolve_recording_directory(recorder, "/var/lib/hapticd:/var/lib/other"),
            std::filesystem::path("/var/lib/hapticd/recordings"));
  recorder.directory = "/data";
  EXPECT_EQ(resolve_recording_directory(recorder, "/var/lib/hapticd"), std::filesystem::path("/data"));
}

TEST(ConfigHelpers, RingCapacity) {
  RecorderConfig recorder;
  EXPECT_EQ(recorder.ring_capacity(1e-3), 2000u);
  EXPECT_EQ(recorder.ring_capacity(100e-6), 20000u);
  recorder.ring_seconds = 0.1;
  EXPECT_EQ(recorder.ring_capacity(3e-3), 34u);
}

}  // namespace
}  // namespace hapticd::daemon::config::config_test
