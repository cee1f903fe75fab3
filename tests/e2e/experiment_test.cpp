// Experiments end to end (issue 13): `hapticctl tune relay` and `hapticctl
// identify` driving the real hapticd on the loopback device, whose plant is
// known, so every estimate is checked against the configured truth; the
// identified model file read back by the daemon (`[device] model`) and used
// by the stability gate; bad model files and flags refused in one clear line.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "tests/e2e/support.hpp"

namespace hapticd::e2e::experiment_test {
namespace {

using nlohmann::json;

// The loopback plants under test (linear, SI), on the virtual clock so a run
// of minutes of device time takes about a second.
std::string loop_and_device() {
  return "[loop]\nperiod = \"1ms\"\nclock = \"virtual\"\n"
         "[device]\ndriver = \"loopback\"\ntorque_limit = 10.0\n";
}

// Appended, not `loop_and_device() + "..."`: GCC 12 at -O3 warns
// -Warray-bounds inside libstdc++ for that (a false positive, GCC bug 105651).
std::string rigid_config() {
  std::string config = loop_and_device();
  config +=
      "[device.loopback]\nmotion = \"linear\"\nplant = \"rigid\"\nmass = 0.5\ndamping = 2.0\ndelay = 1\n"
      "[scene]\nname = \"spring-wheel\"\n";
  return config;
}

// Diaz & Gil Table I (the LHifAM), motor-side sensing.
std::string two_mass_config() {
  std::string config = loop_and_device();
  config +=
      "[device.loopback]\nmotion = \"linear\"\nplant = \"two-mass\"\nmotor_mass = 0.3\nbody_mass = 5.1\n"
      "motor_damping = 0.1\nbody_damping = 3.4\ncable_stiffness = 79500.0\ncable_damping = 15.0\n"
      "sensor = \"motor\"\n[scene]\nname = \"spring-wheel\"\n";
  return config;
}

json parse_out(const CommandResult& r) {
  const json out = json::parse(r.out, nullptr, false);
  EXPECT_FALSE(out.is_discarded()) << r.out << r.err;
  return out;
}

std::string scene_of(const Daemon& d) {
  const auto r = d.ctl({"status", "--json"});
  return json::parse(r.out).at("scene").at("name").get<std::string>();
}

// Each delay's measured K_CR within 2.5 dB of the model's and its frequency
// within 12 % (the bands), on the crossover that sets K_CR; the
// estimate corrected by the simulated relay bias within 0.5 dB and 3 %.
void expect_relay_agrees(const json& out, std::size_t trials) {
  ASSERT_EQ(out.at("trials").size(), trials) << out.dump(1);
  for (const json& t : out["trials"]) {
    SCOPED_TRACE("delay " + std::to_string(t.at("delay_s").get<double>()));
    ASSERT_TRUE(t.at("model").at("assessed").get<bool>()) << t.dump(1);
    EXPECT_TRUE(t.at("on_critical_crossover").get<bool>()) << t.dump(1);
    EXPECT_TRUE(t.at("warning").is_null()) << t.dump(1);
    const double model_db = t["model"]["gain_margin_db"].get<double>();
    const double model_hz = t["model"]["frequency_hz"].get<double>();
    EXPECT_LT(std::abs(t.at("gain_margin_db").get<double>() - model_db), 2.5) << t.dump(1);
    EXPECT_LT(std::abs(t.at("frequency_hz").get<double>() / model_hz - 1.0), 0.12) << t.dump(1);
    ASSERT_TRUE(t.contains("corrected")) << t.dump(1);
    EXPECT_LT(std::abs(t["corrected"]["gain_margin_db"].get<double>() - model_db), 0.5) << t.dump(1);
    EXPECT_LT(std::abs(t["corrected"]["frequency_hz"].get<double>() / model_hz - 1.0), 0.03) << t.dump(1);
  }
}

TEST(Experiment, TuneRelayOnRigidLoopbackAgreesWithTheModelAtFourDelays) {
  TempDir dir;
  Daemon d(dir, rigid_config());
  const auto r = d.ctl({"tune", "relay", "--delay", "0,2ms,4ms,8ms", "--duration", "10s", "--out",
                        (dir.path / "tune").string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const json out = parse_out(r);
  expect_relay_agrees(out, 4);
  EXPECT_EQ(out.at("model_source"), "config");
  EXPECT_EQ(scene_of(d), "spring-wheel") << "the scene loaded before the run is restored";
  EXPECT_TRUE(std::filesystem::exists(dir.path / "tune" / "relay_gain_margin.csv"));
  EXPECT_TRUE(d.running());
}

TEST(Experiment, TuneRelayOnTwoMassLoopbackAgreesWithTheModelAtThreeDelays) {
  TempDir dir;
  Daemon d(dir, two_mass_config());
  const auto r = d.ctl({"tune", "relay", "--delay", "0,4ms,8ms", "--duration", "20s", "--out",
                        (dir.path / "tune").string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  expect_relay_agrees(parse_out(r), 3);
  EXPECT_EQ(scene_of(d), "spring-wheel");
}

struct Estimate {
  double value = 0.0, half_width = 0.0;
};

std::map<std::string, Estimate> estimates(const json& out) {
  std::map<std::string, Estimate> by_name;
  for (const json& p : out.at("parameters")) {
    by_name[p.at("name").get<std::string>()] = {p.at("value").get<double>(),
                                                p.at("half_width").get<double>()};
  }
  return by_name;
}

// The configured value lies inside the 95 % interval and within `band`
// (relative) of the estimate.
void expect_recovered(const std::map<std::string, Estimate>& fit, const std::string& name, double truth,
                      double band) {
  ASSERT_TRUE(fit.count(name)) << name;
  const Estimate& e = fit.at(name);
  EXPECT_TRUE(std::isfinite(e.half_width) && e.half_width > 0.0) << name << " +- " << e.half_width;
  EXPECT_LE(std::abs(e.value - truth), e.half_width)
      << name << " = " << e.value << " +- " << e.half_width << ", configured " << truth;
  EXPECT_LE(std::abs(e.value / truth - 1.0), band) << name << " = " << e.value << ", configured " << truth;
}

TEST(Experiment, IdentifyRigidLoopbackRecoversMassDampingAndDelayWithinTheirIntervals) {
  TempDir dir;
  Daemon d(dir, rigid_config());
  const auto r = d.ctl({"identify", "--out", (dir.path / "id").string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const json out = parse_out(r);
  EXPECT_EQ(out.at("plant"), "rigid");
  const auto fit = estimates(out);
  expect_recovered(fit, "mass", 0.5, 0.02);
  expect_recovered(fit, "damping", 2.0, 0.02);
  expect_recovered(fit, "delay", 1.0, 0.02);
  EXPECT_EQ(out.at("model").at("delay"), 1);
  EXPECT_TRUE(std::filesystem::exists(out.at("model_file").get<std::string>()));
  EXPECT_EQ(scene_of(d), "spring-wheel");
}

TEST(Experiment, IdentifyTwoMassLoopbackRecoversTableOneWithinTheirIntervals) {
  TempDir dir;
  Daemon d(dir, two_mass_config());
  const auto r = d.ctl({"identify", "--out", (dir.path / "id").string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const json out = parse_out(r);
  EXPECT_EQ(out.at("plant"), "two-mass");
  const auto fit = estimates(out);
  expect_recovered(fit, "motor_mass", 0.3, 0.05);
  expect_recovered(fit, "body_mass", 5.1, 0.05);
  expect_recovered(fit, "cable_stiffness", 79500.0, 0.05);
  expect_recovered(fit, "cable_damping", 15.0, 0.05);
  expect_recovered(fit, "body_damping", 3.4, 0.05);
  // b_m alone is loose (b_m + b_d is what a free device shows): the command says so.
  ASSERT_EQ(out.at("confounded").size(), 1u) << out.dump(1);
  const json& pair = out["confounded"][0];
  EXPECT_EQ(pair.at("first"), "motor_damping");
  EXPECT_EQ(pair.at("second"), "body_damping");
  // Within the 5 %, not asserted inside its interval: that interval
  // (7e-5 N s/m) is as narrow as the bias encoder quantization leaves, which
  // is not the white noise the interval assumes (README, Measured).
  EXPECT_LE(std::abs(pair.at("sum").get<double>() / 3.5 - 1.0), 0.05) << pair;
  EXPECT_EQ(scene_of(d), "spring-wheel");
}

// The loopback's hand scripted to hold the body still (two-mass) or to hold
// it with a spring (rigid): the motor side and the cable, or the mass with
// the hand's spring, recovered within the bands; the command says it
// is not a device model for the gate and writes no model file.
TEST(Experiment, IdentifyWithTheHandHoldingOrOnASpringRecoversWhatThatRunShows) {
  TempDir dir;
  {
    Daemon d(dir, two_mass_config());
    const auto r = d.ctl({"identify", "--hand", "hold", "--out", (dir.path / "hold").string(), "--json"});
    ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
    const json out = parse_out(r);
    const auto fit = estimates(out);
    for (const auto& [name, truth] :
         {std::pair{"motor_mass", 0.3}, {"cable_stiffness", 79500.0}, {"motor_and_cable_damping", 15.1}}) {
      ASSERT_TRUE(fit.count(name)) << name;
      EXPECT_LE(std::abs(fit.at(name).value / truth - 1.0), 0.05) << name << " = " << fit.at(name).value;
    }
    EXPECT_FALSE(out.at("complete").get<bool>());
    EXPECT_FALSE(out.contains("model_file")) << out.dump(1);
    EXPECT_EQ(scene_of(d), "spring-wheel");
  }
  Daemon d(dir, rigid_config());
  const auto r = d.ctl({"identify", "--hand", "spring", "--hand-stiffness", "20", "--out",
                        (dir.path / "spring").string(), "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  const json out = parse_out(r);
  const auto fit = estimates(out);
  expect_recovered(fit, "mass", 0.5, 0.02);
  ASSERT_TRUE(fit.count("hand_stiffness"));
  EXPECT_LE(std::abs(fit.at("hand_stiffness").value / 20.0 - 1.0), 0.02) << fit.at("hand_stiffness").value;
  EXPECT_FALSE(out.at("complete").get<bool>());
}

std::string device_model_of(const Daemon& d) {
  const auto r = d.ctl({"status", "--json"});
  return json::parse(r.out).at("device").at("model_source").get<std::string>();
}

// A wall the configured plant (m = 0.5 kg, b = 2 N s/m, d = 1) holds, and
// that 12 periods of delay would not (K_CR = 497 N/m there).
std::string wall_scene() {
  return "[scene]\nname = \"wall\"\nstiffness = 2000.0\ndamping = 5.0\nposition = 0.05\n";
}

// The rigid config with `[device] model = "<path>"` and the wall scene.
std::string config_naming(const std::string& model_path) {
  std::string c = rigid_config();
  c = c.substr(0, c.find("[scene]"));
  c.replace(c.find("torque_limit = 10.0\n"), 20, "torque_limit = 10.0\nmodel = \"" + model_path + "\"\n");
  return c + wall_scene();
}

CommandResult check_config(const TempDir& dir, const std::string& text) {
  const auto config = dir.path / "check.toml";
  std::ofstream(config) << text;
  return run(hapticd_binary(), {"--check-config", "-c", config.string()});
}

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

/// The model file with the line starting `key = ` replaced by `line` ("" removes it).
std::string with_line(const std::string& file, const std::string& key, const std::string& line) {
  std::istringstream in(file);
  std::string out;
  for (std::string l; std::getline(in, l);) out += (l.starts_with(key + " = ") ? line : l) + "\n";
  return out;
}

// identify --apply: the gate uses the identified model at once (status names
// the file); the file, named in a config, is accepted by a new hapticd, whose
// gate then uses it: with the delay raised to 12 periods in the file the wall
// that the identified model holds is refused, naming d = 12.
TEST(Experiment, IdentifyApplyWritesAModelFileTheDaemonAcceptsAndTheGateUses) {
  TempDir dir;
  const auto model = dir.path / "device-model.toml";
  {
    Daemon d(dir, rigid_config());
    EXPECT_EQ(device_model_of(d), "config");
    const auto r = d.ctl({"identify", "--out", (dir.path / "id").string(), "--model-file", model.string(),
                          "--apply", "--json"});
    ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
    const json out = parse_out(r);
    EXPECT_EQ(out.at("applied").at("model").at("source"), "identified: " + model.string());
    EXPECT_EQ(device_model_of(d), "identified: " + model.string());
    EXPECT_EQ(out.at("applied").at("model").at("delay_periods"), 1);
  }
  const std::string text = read_text(model);
  ASSERT_NE(text.find("[model]"), std::string::npos) << text;

  auto r = check_config(dir, config_naming(model.string()));
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("identified"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("scene: wall"), std::string::npos) << r.out;

  const auto slow = dir.path / "slow-model.toml";
  std::ofstream(slow) << with_line(text, "delay", "delay = 12");
  r = check_config(dir, config_naming(slow.string()));
  EXPECT_EQ(r.exit_code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("wall: unstable on this device"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("d = 12"), std::string::npos) << r.err;

  // The running daemon reads it at start, relative to the config's directory.
  Daemon d(dir, config_naming(model.filename().string()));
  EXPECT_EQ(device_model_of(d), "identified: " + model.string());
  EXPECT_EQ(scene_of(d), "wall");
}

// A model file that is missing or holds a non-finite number, a number in
// other units (a string), the other motion, another period, a fractional
// delay, a negative damping, an unknown key or a missing one: hapticd refuses
// it in one line naming the file's position and what is accepted.
TEST(Experiment, BadModelFilesAreRefusedAtTheirKeyWithWhatIsAccepted) {
  TempDir dir;
  std::string good;
  {
    Daemon d(dir, rigid_config());
    const auto r = d.ctl({"identify", "--out", (dir.path / "id").string(), "--json"});
    ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
    good = read_text(parse_out(r).at("model_file").get<std::string>());
  }
  auto r = check_config(dir, config_naming("absent.toml"));
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("check.toml:7:9: cannot read the model file " + (dir.path / "absent.toml").string()),
            std::string::npos)
      << r.err;
  struct Case {
    std::string key, line, expected;
  };
  const std::vector<Case> cases = {
      {"mass", "mass = nan", "model.mass = nan is out of range"},
      {"mass", "mass = inf", "model.mass = inf is out of range"},
      {"mass", "mass = \"0.5 kg\"", "model.mass = \"0.5 kg\" is not accepted; a number >= 1e-09"},
      {"motion", "motion = \"rotary\"",
       "model.motion = \"rotary\" does not match the device, which is linear"},
      {"period", "period = 0.002", "identified at a period of 2 ms and the loop runs at 1 ms"},
      {"delay", "delay = 1.5", "model.delay = 1.5 is not a whole number of periods"},
      {"damping", "damping = -1", "model.damping = -1.0 is not accepted; a number >= 0"},
      {"coulomb", "inertia = 0.5", "unknown key 'inertia' for plant = \"rigid\"; accepted: plant, motion"},
      {"mass", "", "model.mass is missing; accepted: a number >= 1e-09"},
  };
  const auto file = dir.path / "bad-model.toml";
  for (const Case& c : cases) {
    SCOPED_TRACE(c.line);
    std::ofstream(file) << with_line(good, c.key, c.line);
    r = check_config(dir, config_naming(file.string()));
    EXPECT_EQ(r.exit_code, 2) << r.out;
    EXPECT_NE(r.err.find("bad-model.toml"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find(c.expected), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
  }
}

// Flags with non-finite numbers, wrong units or out of range are refused in
// one line before anything moves: the scene stays, nothing is "restored".
TEST(Experiment, BadFlagsAreRefusedBeforeTheDeviceMoves) {
  TempDir dir;
  Daemon d(dir, rigid_config());
  const std::string out = (dir.path / "out").string();
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{"tune", "relay", "--amplitude", "nan"}, "--amplitude: 'nan' is not accepted; a finite number > 0"},
      {{"tune", "relay", "--amplitude", "5N"}, "--amplitude: '5N' is not accepted"},
      {{"tune", "relay", "--amplitude", "50"}, "above the daemon's torque limit 10 N"},
      {{"tune", "relay", "--delay", "1.5ms"}, "--delay: 1.5ms is not a whole number of loop periods"},
      {{"tune", "relay", "--delay", "2kg"}, "--delay: '2kg' is not accepted"},
      {{"tune", "relay", "--hysteresis", "-1"}, "--hysteresis: '-1' is not accepted"},
      {{"identify", "--amplitude", "inf"}, "--amplitude: 'inf' is not accepted"},
      {{"identify", "--end-frequency", "900"}, "at most at 1/(2T) = 500 Hz"},
      {{"identify", "--hand", "squeeze"}, "--hand: 'squeeze' is not accepted; free, hold or spring"},
      {{"identify", "--apply", "--hand", "hold"}, "--apply needs --hand free"},
  };
  const std::uint64_t before = json::parse(d.ctl({"status", "--json"}).out).at("cycle").get<std::uint64_t>();
  for (auto [args, expected] : cases) {
    args.insert(args.end(), {"--out", out});
    const auto r = d.ctl(args);
    SCOPED_TRACE(args[0] + " " + args[2]);
    EXPECT_NE(r.exit_code, 0) << r.out;
    EXPECT_NE(r.err.find(expected), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("restored"), std::string::npos) << r.err;
  }
  const json status = json::parse(d.ctl({"status", "--json"}).out);
  EXPECT_EQ(status.at("scene").at("name"), "spring-wheel");
  EXPECT_EQ(status.at("device").at("model_source"), "config");
  EXPECT_GT(status.at("cycle").get<std::uint64_t>(), before);
}

json ask(const Daemon& d, const json& request) {
  RawConnection c(d.socket());
  EXPECT_TRUE(c.send(request.dump() + "\n"));
  const std::string reply = c.read_line();
  return reply.empty() ? json() : json::parse(reply, nullptr, false);
}

// device.model.set (what --apply sends) with a model the loaded wall would
// not be stable on is refused, naming the scene; the gate's model stays; a
// key out of range is invalid params at that key.
TEST(Experiment, DeviceModelSetIsRefusedWhenTheLoadedSceneWouldNotBeStableOnIt) {
  TempDir dir;
  std::string c = rigid_config();
  Daemon d(dir, c.substr(0, c.find("[scene]")) + wall_scene());
  json model{{"plant", "rigid"}, {"motion", "linear"}, {"period", 0.001},
             {"delay", 12},      {"mass", 0.5},        {"damping", 2.0}};
  json reply = ask(d, {{"jsonrpc", "2.0"},
                       {"id", 1},
                       {"method", "device.model.set"},
                       {"params", {{"model", model}, {"file", "/tmp/m.toml"}}}});
  ASSERT_TRUE(reply.contains("error")) << reply.dump();
  EXPECT_EQ(reply["error"]["code"], -32000) << reply.dump();
  EXPECT_NE(reply["error"]["message"].get<std::string>().find("the loaded scene wall would not be stable"),
            std::string::npos)
      << reply.dump();
  EXPECT_EQ(device_model_of(d), "config");
  model["delay"] = 1;
  model["mass"] = -1.0;
  reply =
      ask(d, {{"jsonrpc", "2.0"}, {"id", 2}, {"method", "device.model.set"}, {"params", {{"model", model}}}});
  ASSERT_TRUE(reply.contains("error")) << reply.dump();
  EXPECT_EQ(reply["error"]["code"], -32602) << reply.dump();
  EXPECT_NE(reply["error"]["message"].get<std::string>().find("model.mass = -1.0 is not accepted"),
            std::string::npos)
      << reply.dump();
  EXPECT_EQ(device_model_of(d), "config");
  model["mass"] = 0.5;
  reply =
      ask(d, {{"jsonrpc", "2.0"}, {"id", 3}, {"method", "device.model.set"}, {"params", {{"model", model}}}});
  ASSERT_TRUE(reply.contains("result")) << reply.dump();
  EXPECT_EQ(device_model_of(d), "identified");
}

// Ctrl-C during a run: exit 130, the loaded scene restored, the recording
// stopped, nothing written.
TEST(Experiment, CtrlCDuringTheRelayRestoresTheSceneAndStopsTheRecording) {
  TempDir dir;
  Daemon d(dir, rigid_config());
  const auto r = run(
      "/usr/bin/timeout",
      {"--preserve-status", "-s", "INT", "1", hapticctl_binary().string(), "--socket", d.socket().string(),
       "tune", "relay", "--duration", "20000s", "--out", (dir.path / "tune").string()},
      std::chrono::seconds(60));
  EXPECT_EQ(r.exit_code, 130) << r.out << r.err;
  EXPECT_NE(r.err.find("stopped by Ctrl-C; recording stopped; scene spring-wheel restored"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.path / "tune" / "relay_trials.json"));
  const json status = json::parse(d.ctl({"status", "--json"}).out);
  EXPECT_EQ(status.at("scene").at("name"), "spring-wheel");
  const auto stop = d.ctl({"record", "stop"});
  EXPECT_NE(stop.exit_code, 0) << "no recording left running: " << stop.out;
}

}  // namespace
}  // namespace hapticd::e2e::experiment_test
