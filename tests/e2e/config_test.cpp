// End-to-end: what `hapticd --check-config` and start-up make of a config
// file: host problems (socket directory and path, control group, recording
// directory) are config errors at the key's file:line:column, and a file
// that leaves keys out runs what the built-in default runs.

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "support.hpp"

namespace hapticd::e2e::config_test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct HostCase {
  std::string name;
  std::string toml;      ///< the whole config file
  std::string position;  ///< "bad.toml:L:C: key = ..."
  std::string accepted;  ///< a piece of the accepted text
};

TEST(CheckConfig, HostProblemsAreConfigErrorsAtTheKey) {
  TempDir dir;
  const std::string d = dir.path.string();
  std::ofstream(dir.path / "plain-file") << "not a directory";
  const std::vector<HostCase> cases{
      {"missing socket directory", "[control]\nsocket = \"" + d + "/missing/h.sock\"\n",
       "bad.toml:2:10: control.socket = \"" + d + "/missing/h.sock\": directory " + d +
           "/missing does not exist",
       "accepted: \"\" (the default path) or a path in an existing directory"},
      {"socket path is a regular file", "[control]\nsocket = \"" + d + "/plain-file\"\n",
       "bad.toml:2:10: control.socket = \"" + d + "/plain-file\": " + d +
           "/plain-file is a regular file, not a socket",
       "free or holding a stale hapticd socket"},
      {"unknown group", "[control]\nsocket = \"" + d + "/h.sock\"\ngroup = \"hapticd-no-such-group\"\n",
       "bad.toml:3:9: control.group = \"hapticd-no-such-group\": no such group on this host",
       "the name of an existing group"},
      {"recording directory under a regular file",
       "[control]\nsocket = \"" + d + "/h.sock\"\n[recorder]\ndirectory = \"" + d + "/plain-file/rec\"\n",
       "bad.toml:4:13: recorder.directory = \"" + d + "/plain-file/rec\": cannot create " + d +
           "/plain-file/rec: Not a directory",
       "a directory the daemon can create files in (created if missing)"},
  };
  const fs::path config = dir.path / "bad.toml";
  for (const auto& c : cases) {
    SCOPED_TRACE(c.name);
    std::ofstream(config) << c.toml;
    const auto check = run(hapticd_binary(), {"--config", config.string(), "--check-config"});
    EXPECT_EQ(check.exit_code, 2) << check.out << check.err;
    EXPECT_EQ(check.err.rfind("hapticd: " + dir.path.string() + "/" + c.position, 0), 0u) << check.err;
    EXPECT_NE(check.err.find(c.accepted), std::string::npos) << check.err;
    EXPECT_EQ(check.out.find("config OK"), std::string::npos) << check.out;
    // Start-up refuses the same way (a wrongly accepted config would stop
    // by itself after 0.1 s of virtual loop time).
    const auto start =
        run(hapticd_binary(), {"--config", config.string(), "--clock", "virtual", "--duration", "100ms"});
    EXPECT_EQ(start.exit_code, 2) << start.out << start.err;
    EXPECT_EQ(start.err, check.err);
  }
  // --socket names itself, not the file.
  const auto flag = run(hapticd_binary(), {"--socket", d + "/plain-file", "--check-config"});
  EXPECT_EQ(flag.exit_code, 2) << flag.err;
  EXPECT_EQ(flag.err.rfind("hapticd: --socket: control.socket = ", 0), 0u) << flag.err;
}

TEST(CheckConfig, MissingRecordingDirectoryIsCreated) {
  TempDir dir;
  const fs::path config = dir.path / "ok.toml";
  const fs::path recordings = dir.path / "a" / "b";
  std::ofstream(config) << "[recorder]\ndirectory = \"" << recordings.string() << "\"\n";
  const auto r = run(hapticd_binary(), {"--config", config.string(), "--check-config"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::is_directory(recordings));
}

// Issue 17: the position-step rule in force, from [device] max_velocity or
// derived from the device (docs/config.md): 50 rad/s for the hand plus
// sqrt(2 x 1 N m x 2 pi / 0.01 kg m^2) for the loopback wheel's motor.
TEST(CheckConfig, PrintsThePositionStepRuleInForce) {
  TempDir dir;
  const fs::path derived = dir.path / "derived.toml";
  const fs::path given = dir.path / "given.toml";
  std::ofstream(derived) << "[recorder]\ndirectory = \"" << dir.path.string() << "\"\n";
  std::ofstream(given) << "[device]\nmax_velocity = 120\n[recorder]\ndirectory = \"" << dir.path.string()
                       << "\"\n";
  const auto a = run(hapticd_binary(), {"--config", derived.string(), "--check-config"});
  const auto b = run(hapticd_binary(), {"--config", given.string(), "--check-config"});
  ASSERT_EQ(a.exit_code, 0) << a.err;
  ASSERT_EQ(b.exit_code, 0) << b.err;
  EXPECT_NE(a.out.find("plausibility: max_velocity 85.4491 rad/s (derived from the device), a position step "
                       "over 0.0858326 rad (223.8 counts) in one period of 1 ms latches \"encoder jump / "
                       "velocity limit\""),
            std::string::npos)
      << a.out;
  EXPECT_NE(b.out.find("plausibility: max_velocity 120 rad/s (device.max_velocity), a position step over "
                       "0.120383 rad"),
            std::string::npos)
      << b.out;
}

// Issue 6: a file with only [control] socket and [recorder] directory was
// refused ("spring-wheel: unstable on this device ... pole radius
// 1.000032577"): without [device.loopback] the wheel had no damping, while
// the built-in default gave it 0.002 N m s/rad.
TEST(CheckConfig, MinimalFileRunsWhatTheBuiltInDefaultRuns) {
  TempDir dir;
  const fs::path minimal = dir.path / "minimal.toml";
  std::ofstream(minimal) << "[control]\nsocket = \"" << (dir.path / "h.sock").string()
                         << "\"\n[recorder]\ndirectory = \"" << dir.path.string() << "\"\n";
  // (--socket: the default socket path depends on the environment.)
  const auto builtin = run(hapticd_binary(), {"--socket", (dir.path / "h.sock").string(), "--check-config"});
  const auto from_file = run(hapticd_binary(), {"--config", minimal.string(), "--check-config"});
  ASSERT_EQ(builtin.exit_code, 0) << builtin.err;
  EXPECT_EQ(from_file.exit_code, 0) << from_file.err;
  // Device model, loop, scene with every parameter, stability verdict.
  EXPECT_EQ(from_file.out, builtin.out);
  EXPECT_NE(from_file.out.find("b = 0.002 N m s/rad"), std::string::npos) << from_file.out;

  // And it runs: the Daemon helper writes exactly such a file for "".
  Daemon d(dir, "");
  ASSERT_TRUE(d.running()) << d.log();
  const auto status = d.ctl({"status", "--json"});
  ASSERT_EQ(status.exit_code, 0) << status.err;
  const json s = json::parse(status.out);
  EXPECT_EQ(s["scene"]["name"], json("spring-wheel"));
  EXPECT_TRUE(s["scene"]["stability"]["stable"].get<bool>()) << s.dump();
  EXPECT_EQ(d.stop(), 0) << d.log();
}

// hapticd --setup-check on this machine (issue 23 item 3): the facts are the
// machine's (no PREEMPT_RT here, and so on), so this asserts the report's
// structure and that the exit code, the verdict and the counts agree.
void expect_consistent_setup_report(const CommandResult& r) {
  const json report = json::parse(r.out);
  ASSERT_TRUE(report["items"].is_array()) << r.out;
  int ok = 0, warning = 0, fail = 0;
  for (const auto& item : report["items"]) {
    for (const char* key : {"name", "verdict", "finding", "fix"})
      EXPECT_TRUE(item[key].is_string()) << item.dump();
    const std::string verdict = item["verdict"];
    EXPECT_TRUE(verdict == "ok" || verdict == "warning" || verdict == "fail") << item.dump();
    EXPECT_FALSE(item["finding"].get<std::string>().empty()) << item.dump();
    // Every item not ok says how to fix it.
    EXPECT_EQ(verdict == "ok", item["fix"].get<std::string>().empty()) << item.dump();
    ok += verdict == "ok";
    warning += verdict == "warning";
    fail += verdict == "fail";
  }
  EXPECT_EQ(report["counts"]["ok"], ok);
  EXPECT_EQ(report["counts"]["warning"], warning);
  EXPECT_EQ(report["counts"]["fail"], fail);
  EXPECT_EQ(report["verdict"], fail > 0 ? "fail" : warning > 0 ? "warning" : "ok");
  EXPECT_EQ(r.exit_code, fail > 0 ? 1 : 0) << r.out << r.err;
}

TEST(SetupCheck, OnThisMachineEveryItemHasAVerdictAndTheExitCodeFollows) {
  TempDir dir;
  const fs::path cfg = dir.path / "hapticd.toml";
  std::ofstream(cfg) << "[control]\nsocket = \"" << (dir.path / "h.sock").string()
                     << "\"\n[recorder]\ndirectory = \"" << dir.path.string() << "\"\n";
  const CommandResult r = run(hapticd_binary(), {"--setup-check", "--json", "-c", cfg.string()});
  expect_consistent_setup_report(r);
  const json report = json::parse(r.out);
  std::vector<std::string> names;
  for (const auto& item : report["items"]) names.push_back(item["name"]);
  EXPECT_EQ(names, (std::vector<std::string>{"rt-priority", "memlock", "kernel", "cpu-isolation",
                                             "cpu-dma-latency", "device", "period", "paths"}));
  EXPECT_EQ(report["driver"], "loopback");
  // The text form: one line per item, the counts last, the same exit code.
  const CommandResult text = run(hapticd_binary(), {"--setup-check", "-c", cfg.string()});
  EXPECT_EQ(text.exit_code, r.exit_code);
  EXPECT_NE(text.out.find("  " + report["items"][2]["verdict"].get<std::string>()), std::string::npos)
      << text.out;
  EXPECT_NE(text.out.find(std::to_string(report["counts"]["fail"].get<int>()) + " failures"),
            std::string::npos)
      << text.out;
}

TEST(SetupCheck, AnAbsentDeviceFailsWithExitOne) {
  TempDir dir;
  const fs::path cfg = dir.path / "usb.toml";
  // An ID no machine here has: the device item fails, whatever else does.
  std::ofstream(cfg) << "[control]\nsocket = \"" << (dir.path / "h.sock").string()
                     << "\"\n[recorder]\ndirectory = \"" << dir.path.string()
                     << "\"\n[device]\ndriver = \"usb-hid\"\n[device.usb-hid]\nvendor_id = \"0x1209\"\n"
                        "product_id = \"0xfffe\"\n";
  const CommandResult r = run(hapticd_binary(), {"--setup-check", "--json", "-c", cfg.string()});
  expect_consistent_setup_report(r);
  EXPECT_EQ(r.exit_code, 1);
  const json report = json::parse(r.out);
  bool device_failed = false;
  for (const auto& item : report["items"])
    device_failed |= item["name"] == "device" && item["verdict"] == "fail";
  EXPECT_TRUE(device_failed) << r.out;
}

TEST(SetupCheck, AConfigThatDoesNotLoadIsAFailure) {
  TempDir dir;
  const fs::path cfg = dir.path / "bad.toml";
  std::ofstream(cfg) << "[loop]\nperiod = \"5s\"\n";
  const CommandResult r = run(hapticd_binary(), {"--setup-check", "--json", "-c", cfg.string()});
  expect_consistent_setup_report(r);
  const json report = json::parse(r.out);
  ASSERT_EQ(report["items"].size(), 1u) << r.out;
  EXPECT_EQ(report["items"][0]["name"], "config");
  EXPECT_NE(report["items"][0]["finding"].get<std::string>().find("loop.period"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace hapticd::e2e::config_test
