#include "daemon/system/rt_setup.hpp"

#include <gtest/gtest.h>
#include <pthread.h>
#include <sched.h>
#include <sys/resource.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>

#include "daemon/system/rt_permission.hpp"

namespace rt_setup_test {

using namespace hapticd::daemon::system;
using Nanos = std::chrono::nanoseconds;

namespace {
bool contains(const std::string& s, const char* part) { return s.find(part) != std::string::npos; }
}  // namespace

TEST(RtPermission, NoCapabilityAndZeroRlimitSaysHowToGrant) {
  SchedPermissionFacts f;
  f.error = EPERM;
  f.requested_priority = 80;
  f.has_cap_sys_nice = false;
  f.rtprio_soft = f.rtprio_hard = 0;
  f.cgroup_rt_runtime_us = 950000;
  const std::string m = explain_sched_failure(f);
  EXPECT_TRUE(contains(m, "EPERM")) << m;
  EXPECT_TRUE(contains(m, "no CAP_SYS_NICE")) << m;
  EXPECT_TRUE(contains(m, "RLIMIT_RTPRIO is 0")) << m;
  EXPECT_TRUE(contains(m, "setcap cap_sys_nice+ep")) << m;
  EXPECT_TRUE(contains(m, "LimitRTPRIO=95")) << m;
  EXPECT_TRUE(contains(m, "@group - rtprio 95")) << m;
  EXPECT_TRUE(contains(m, "/etc/security/limits.d")) << m;
  EXPECT_FALSE(contains(m, "rt_runtime_us")) << m;
}

TEST(RtPermission, EnoughRlimitButZeroCgroupBudgetBlamesTheCgroup) {
  SchedPermissionFacts f;
  f.error = EPERM;
  f.requested_priority = 80;
  f.rtprio_soft = f.rtprio_hard = 95;
  f.cgroup_rt_runtime_file = "/sys/fs/cgroup/cpu,cpuacct/system.slice/hapticd.service/cpu.rt_runtime_us";
  f.cgroup_rt_runtime_us = 0;
  const std::string m = explain_sched_failure(f);
  EXPECT_TRUE(contains(m, "RLIMIT_RTPRIO (95) allows it")) << m;
  EXPECT_TRUE(contains(m, "cpu.rt_runtime_us = 0")) << m;
  EXPECT_TRUE(contains(m, "system.slice/hapticd.service")) << m;
  EXPECT_FALSE(contains(m, "setcap")) << m;
}

TEST(RtPermission, CapabilityPresentAndBudgetNonZeroSaysSomethingElse) {
  SchedPermissionFacts f;
  f.error = EPERM;
  f.requested_priority = 80;
  f.has_cap_sys_nice = true;
  f.cgroup_rt_runtime_file = "/x/cpu.rt_runtime_us";
  f.cgroup_rt_runtime_us = 950000;
  const std::string m = explain_sched_failure(f);
  EXPECT_TRUE(contains(m, "CAP_SYS_NICE")) << m;
  EXPECT_TRUE(contains(m, "is not 0")) << m;
  EXPECT_FALSE(contains(m, "setcap")) << m;
}

TEST(RtPermission, InvalidPriority) {
  SchedPermissionFacts f;
  f.error = EINVAL;
  f.requested_priority = 120;
  EXPECT_TRUE(contains(explain_sched_failure(f), "1..99"));
}

TEST(RtPermission, ParsesCapEff) {
  const std::string status =
      "Name:\tx\nCapInh:\t0000000000000000\nCapEff:\t0000000000800000\nCapBnd:\t000001ffffffffff\n";
  EXPECT_TRUE(status_has_effective_cap(status, 23));
  EXPECT_FALSE(status_has_effective_cap(status, 24));
  EXPECT_FALSE(status_has_effective_cap("CapEff:\t0000000000000000\n", 23));
  EXPECT_FALSE(status_has_effective_cap("garbage", 23));
}

TEST(RtPermission, FindsTheCgroupBudgetFileForV1AndV2) {
  namespace fs = std::filesystem;
  const fs::path root = fs::temp_directory_path() / ("hapticd_cg_" + std::to_string(::getpid()));
  fs::remove_all(root);
  fs::create_directories(root / "cpu,cpuacct/system.slice/hapticd.service");
  std::ofstream(root / "cpu,cpuacct/system.slice/hapticd.service/cpu.rt_runtime_us") << "0\n";
  const auto v1 = find_cgroup_rt_runtime_file(
      "12:memory:/system.slice/hapticd.service\n4:cpu,cpuacct:/system.slice/hapticd.service\n0::/x\n",
      root.string());
  ASSERT_TRUE(v1.has_value());
  EXPECT_EQ(*v1, (root / "cpu,cpuacct/system.slice/hapticd.service/cpu.rt_runtime_us").string());

  fs::create_directories(root / "user.slice");
  std::ofstream(root / "user.slice/cpu.rt_runtime_us") << "0\n";
  const auto v2 = find_cgroup_rt_runtime_file("0::/user.slice\n", root.string());
  ASSERT_TRUE(v2.has_value());
  EXPECT_EQ(*v2, (root / "user.slice/cpu.rt_runtime_us").string());

  EXPECT_FALSE(find_cgroup_rt_runtime_file("0::/nowhere\n", root.string()).has_value());
  fs::remove_all(root);
}

// Whether this process may take SCHED_FIFO at `priority`, decided as the
// project explains refusals (rt_permission.cpp): CAP_SYS_NICE in CapEff
// (read here from /proc/self/status, bit 23) or an RLIMIT_RTPRIO at or above
// the priority (root without CAP_SYS_NICE gets no exemption), and a cgroup RT
// budget that is not 0 (or no cpu.rt_runtime_us at all).
bool may_take_fifo(int priority, std::string* why) {
  std::ifstream status_file("/proc/self/status");
  std::string line;
  bool cap_sys_nice = false;
  while (std::getline(status_file, line)) {
    if (line.rfind("CapEff:", 0) == 0)
      cap_sys_nice = ((std::stoull(line.substr(7), nullptr, 16) >> 23) & 1) != 0;
  }
  rlimit rl{};
  const bool rlimit_ok = ::getrlimit(RLIMIT_RTPRIO, &rl) == 0 &&
                         (rl.rlim_cur == RLIM_INFINITY || rl.rlim_cur >= static_cast<rlim_t>(priority) ||
                          rl.rlim_max == RLIM_INFINITY || rl.rlim_max >= static_cast<rlim_t>(priority));
  std::ifstream cgroup_file("/proc/self/cgroup");
  const std::string cgroup((std::istreambuf_iterator<char>(cgroup_file)), std::istreambuf_iterator<char>());
  long long budget = -1;  // -1: no budget file
  if (const auto file = find_cgroup_rt_runtime_file(cgroup)) std::ifstream(*file) >> budget;
  *why = "euid " + std::to_string(::geteuid()) + ", CAP_SYS_NICE " + (cap_sys_nice ? "yes" : "no") +
         ", RLIMIT_RTPRIO " + (rlimit_ok ? "allows" : "forbids") + ", cgroup budget " +
         std::to_string(budget);
  return (cap_sys_nice || rlimit_ok) && budget != 0;
}

// The real thing on a fresh thread. As root it usually succeeds; either way
// the report must agree with what the kernel says about the thread, and where
// the permissions allow it, it must have succeeded.
TEST(RtSetup, ReportMatchesTheThreadsActualScheduler) {
  RtOptions o;
  o.priority = 10;
  o.cpus = {0};
  o.lock_memory = false;  // process-wide; would pin the sanitizer's shadow memory
  o.hold_dma_latency = false;
  RtSetupReport r;
  int policy = -1;
  sched_param sp{};
  cpu_set_t set;
  std::thread t([&] {
    r = configure_realtime(o);
    pthread_getschedparam(pthread_self(), &policy, &sp);
    pthread_getaffinity_np(pthread_self(), sizeof set, &set);
  });
  t.join();
  std::string why;
  if (may_take_fifo(10, &why)) {
    EXPECT_TRUE(r.scheduler_set) << "permitted (" << why << ") but: " << r.message();
  }
  if (r.scheduler_set) {
    EXPECT_EQ(policy, SCHED_FIFO);
    EXPECT_EQ(sp.sched_priority, 10);
    EXPECT_EQ(r.priority, 10);
  } else {
    EXPECT_EQ(policy, SCHED_OTHER);
    EXPECT_TRUE(contains(r.message(), "SCHED_FIFO priority 10 refused")) << r.message();
    EXPECT_TRUE(contains(r.message(), "best-effort")) << r.message();
  }
  if (r.affinity_set) {
    EXPECT_EQ(CPU_COUNT(&set), 1);
    EXPECT_TRUE(CPU_ISSET(0, &set));
  }
  EXPECT_FALSE(r.fatal);
  EXPECT_TRUE(r.stack_prefaulted);
  EXPECT_EQ(r.stack_prefaulted_bytes, 256u * 1024u);
}

TEST(RtSetup, InvalidPriorityIsFatalOnlyWhenRequired) {
  RtOptions o;
  o.priority = 150;
  o.lock_memory = false;
  o.hold_dma_latency = false;
  o.prefault_stack_bytes = 0;
  o.require_rt = true;
  RtSetupReport r;
  std::thread([&] { r = configure_realtime(o); }).join();
  EXPECT_FALSE(r.scheduler_set);
  EXPECT_TRUE(r.fatal);
  EXPECT_TRUE(contains(r.message(), "1..99")) << r.message();
  EXPECT_TRUE(contains(r.message(), "require_rt")) << r.message();

  o.require_rt = false;
  std::thread([&] { r = configure_realtime(o); }).join();
  EXPECT_FALSE(r.fatal);
  EXPECT_TRUE(contains(r.message(), "best-effort")) << r.message();
}

TEST(RtSetup, NonexistentCpuIsReported) {
  RtOptions o;
  o.priority = 0;
  o.cpus = {1000};
  o.lock_memory = false;
  o.hold_dma_latency = false;
  o.prefault_stack_bytes = 0;
  RtSetupReport r;
  std::thread([&] { r = configure_realtime(o); }).join();
  EXPECT_FALSE(r.affinity_set);
  EXPECT_TRUE(contains(r.message(), "CPU affinity {1000}")) << r.message();
}

TEST(CpuDmaLatency, MissingDeviceIsAClearErrorAndNotHeld) {
  std::string err;
  auto req = CpuDmaLatencyRequest::open(0, &err, "/nonexistent/cpu_dma_latency");
  EXPECT_FALSE(req.held());
  EXPECT_TRUE(contains(err, "/nonexistent/cpu_dma_latency")) << err;
}

}  // namespace rt_setup_test
