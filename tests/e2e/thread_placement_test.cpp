// End-to-end: where the daemon's threads run. With [loop] cpu set, the RT
// thread is on that CPU and every other thread keeps off it (on a kernel
// without full preemption a thread inside a long write() on the loop's CPU
// delays the loop's wake-up: bench/latency.sh); [control] cpu and
// [recorder] cpu place those two explicitly.

#include <gtest/gtest.h>

#include <sched.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "support.hpp"

namespace hapticd::e2e::thread_placement_test {
namespace {

namespace fs = std::filesystem;

/// Cpus_allowed_list of each named thread of `pid`, by name (comm).
std::map<std::string, std::string> placement(pid_t pid) {
  std::map<std::string, std::string> out;
  for (const auto& task : fs::directory_iterator(fs::path("/proc") / std::to_string(pid) / "task")) {
    std::ifstream comm(task.path() / "comm");
    std::string name;
    std::getline(comm, name);
    std::ifstream status(task.path() / "status");
    for (std::string line; std::getline(status, line);) {
      if (line.starts_with("Cpus_allowed_list:")) {
        std::string list = line.substr(line.find(':') + 1);
        list.erase(0, list.find_first_not_of(" \t"));
        out[name] = list;
      }
    }
  }
  return out;
}

/// The loop on CPU 1; the control and recorder CPUs as given ("": not set).
std::string config(const TempDir& dir, const std::string& control_cpu, const std::string& recorder_cpu) {
  std::string c = "[loop]\nperiod = \"1ms\"\ncpu = 1\noverrun_limit = 0\n[device]\ndriver = \"loopback\"\n";
  c += "[control]\nsocket = \"" + (dir.path / "hapticd.sock").string() + "\"\n";
  if (!control_cpu.empty()) c += "cpu = " + control_cpu + "\n";
  c += "[recorder]\ndirectory = \"" + dir.path.string() + "\"\n";
  if (!recorder_cpu.empty()) c += "cpu = " + recorder_cpu + "\n";
  return c;
}

bool cpus_0_and_1_available() {
  cpu_set_t set;
  return sched_getaffinity(0, sizeof set, &set) == 0 && CPU_ISSET(0, &set) && CPU_ISSET(1, &set);
}

TEST(ThreadPlacement, EveryOtherThreadKeepsOffTheLoopsCpu) {
  if (!cpus_0_and_1_available()) GTEST_SKIP() << "needs CPUs 0 and 1";
  TempDir dir;
  Daemon d(dir, config(dir, "", ""));
  ASSERT_TRUE(d.running()) << d.log();
  const auto threads = placement(d.pid());
  ASSERT_TRUE(threads.contains("hapticd-rt")) << d.log();
  EXPECT_EQ(threads.at("hapticd-rt"), "1");
  ASSERT_TRUE(threads.contains("hapticd-ctl"));
  ASSERT_TRUE(threads.contains("hapticd-rec"));
  for (const auto& [name, cpus] : threads) {
    if (name == "hapticd-rt") continue;
    // Any list without CPU 1: "0", "0,2-3", ...
    const std::string padded = "," + cpus + ",";
    EXPECT_EQ(padded.find(",1,"), std::string::npos) << name << " may run on the loop's CPU: " << cpus;
    EXPECT_EQ(padded.find(",1-"), std::string::npos) << name << ": " << cpus;
    EXPECT_EQ(padded.find("0-"), std::string::npos) << name << ": " << cpus;
  }
  EXPECT_EQ(d.stop(), 0) << d.log();
}

TEST(ThreadPlacement, ControlAndRecorderGoWhereTheConfigSays) {
  if (!cpus_0_and_1_available()) GTEST_SKIP() << "needs CPUs 0 and 1";
  TempDir dir;
  Daemon d(dir, config(dir, "0", "1"));
  ASSERT_TRUE(d.running()) << d.log();
  const auto threads = placement(d.pid());
  EXPECT_EQ(threads.at("hapticd-rt"), "1");
  EXPECT_EQ(threads.at("hapticd-ctl"), "0");
  EXPECT_EQ(threads.at("hapticd-rec"), "1");  // asked for, though it shares the loop's CPU
  EXPECT_EQ(d.stop(), 0) << d.log();
}

}  // namespace
}  // namespace hapticd::e2e::thread_placement_test
