// hapticd --setup-check, item by item, on fake /proc, /sys and /dev trees
// (daemon/config/host_checks_setup.hpp): each check's verdict and fix from
// the files a machine would have, and from the facts of a process.

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <string>

#include "daemon/config/host_checks_setup.hpp"

namespace hapticd::daemon::config::setup_check_test {
namespace {

namespace fs = std::filesystem;

class FakeHost : public ::testing::Test {
 protected:
  void SetUp() override {
    root = fs::temp_directory_path() / ("hapticd-setup-" + std::to_string(::getpid()) + "-" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root);
    context.proc_root = (root / "proc").string();
    context.sys_root = (root / "sys").string();
    context.dev_root = (root / "dev").string();
    // Not root, not the owner of the files, in their group.
    facts.user = {"svc", 54321, static_cast<std::uint32_t>(::getegid()), {}};
  }
  void TearDown() override { fs::remove_all(root); }

  /// Writes `text` at root/relative with `mode`.
  std::string file(const std::string& relative, const std::string& text, fs::perms mode = fs::perms(0644)) {
    const fs::path path = root / relative;
    fs::create_directories(path.parent_path());
    std::ofstream(path) << text;
    fs::permissions(path, mode);
    return path.string();
  }

  static DaemonConfig config_with(const std::string& device_toml, const std::string& loop_toml = "") {
    return parse_config(
        "[loop]\n" + (loop_toml.empty() ? std::string("period = \"1ms\"") : loop_toml) + "\n" + device_toml,
        "t.toml");
  }

  static const SetupItem& named(const std::vector<SetupItem>& items, const std::string& name) {
    for (const auto& i : items)
      if (i.name == name) return i;
    throw std::runtime_error("no item " + name);
  }

  fs::path root;
  SetupContext context;
  SetupFacts facts;
};

constexpr std::uint64_t unlimited = std::numeric_limits<std::uint64_t>::max();

TEST_F(FakeHost, RtPriorityFromCapabilityLimitAndCgroupBudget) {
  const DaemonConfig cfg = default_config();
  facts.cap_sys_nice = true;
  EXPECT_EQ(check_rt_priority(cfg, facts, context).verdict, Verdict::ok);
  facts.cap_sys_nice = false;
  facts.rtprio_soft = facts.rtprio_hard = 95;
  EXPECT_EQ(check_rt_priority(cfg, facts, context).verdict, Verdict::ok);
  // RLIMIT_RTPRIO 0, no capability: a shell's lack, a warning (the unit grants it) ...
  facts.rtprio_soft = facts.rtprio_hard = 0;
  SetupItem shell = check_rt_priority(cfg, facts, context);
  EXPECT_EQ(shell.verdict, Verdict::warning);
  EXPECT_NE(shell.finding.find("RLIMIT_RTPRIO is 0"), std::string::npos) << shell.finding;
  EXPECT_NE(shell.fix.find("LimitRTPRIO=95"), std::string::npos) << shell.fix;
  // ... and a failure for the service itself.
  facts.under_systemd = true;
  EXPECT_EQ(check_rt_priority(cfg, facts, context).verdict, Verdict::fail);
  // A cgroup without an RT budget refuses even with CAP_SYS_NICE.
  facts.cap_sys_nice = true;
  file("proc/self/cgroup", "0::/system.slice/hapticd.service\n");
  file("sys/fs/cgroup/system.slice/hapticd.service/cpu.rt_runtime_us", "0\n");
  const SetupItem budget = check_rt_priority(cfg, facts, context);
  EXPECT_EQ(budget.verdict, Verdict::fail);
  EXPECT_NE(budget.finding.find("cpu.rt_runtime_us = 0"), std::string::npos) << budget.finding;
}

TEST_F(FakeHost, MemlockNeedsUnlimitedOrCapIpcLock) {
  const DaemonConfig cfg = default_config();
  facts.memlock_soft = 8U << 20U;
  const SetupItem low = check_memlock(cfg, facts);
  EXPECT_EQ(low.verdict, Verdict::warning);
  EXPECT_NE(low.fix.find("LimitMEMLOCK=infinity"), std::string::npos) << low.fix;
  facts.memlock_soft = unlimited;
  EXPECT_EQ(check_memlock(cfg, facts).verdict, Verdict::ok);
  facts.memlock_soft = 0;
  facts.cap_ipc_lock = true;
  EXPECT_EQ(check_memlock(cfg, facts).verdict, Verdict::ok);
}

TEST_F(FakeHost, KernelPreemptRtOrWhatItMeansForThePeriod) {
  DaemonConfig cfg = default_config();
  file("proc/sys/kernel/version", "#1 SMP PREEMPT_DYNAMIC Debian 6.1.0-18\n");
  const SetupItem plain = check_kernel(cfg, context);
  EXPECT_EQ(plain.verdict, Verdict::warning);
  EXPECT_NE(plain.finding.find("not a PREEMPT_RT kernel"), std::string::npos) << plain.finding;
  EXPECT_NE(plain.fix.find("linux-image-rt"), std::string::npos) << plain.fix;
  EXPECT_EQ(plain.finding.find("below 500 us"), std::string::npos);
  cfg.loop.period_s = 250e-6;
  EXPECT_NE(check_kernel(cfg, context).finding.find("below 500 us"), std::string::npos);
  file("sys/kernel/realtime", "1\n");
  EXPECT_EQ(check_kernel(cfg, context).verdict, Verdict::ok);
  fs::remove(root / "sys/kernel/realtime");
  file("proc/sys/kernel/version", "#1 SMP PREEMPT_RT Debian 6.1.0-18-rt\n");
  EXPECT_EQ(check_kernel(cfg, context).verdict, Verdict::ok);
}

TEST_F(FakeHost, CpuIsolationAgainstLoopCpu) {
  file("sys/devices/system/cpu/online", "0-3\n");
  file("sys/devices/system/cpu/isolated", "2\n");
  file("proc/cmdline", "BOOT_IMAGE=/vmlinuz root=/dev/sda1 isolcpus=domain,managed_irq,3 quiet\n");
  DaemonConfig cfg = default_config();
  const SetupItem unpinned = check_cpu_isolation(cfg, context);
  EXPECT_EQ(unpinned.verdict, Verdict::warning);
  EXPECT_NE(unpinned.finding.find("CPUs 2,3 are isolated"), std::string::npos) << unpinned.finding;
  cfg.loop.cpu = 2;
  EXPECT_EQ(check_cpu_isolation(cfg, context).verdict, Verdict::ok);
  cfg.loop.cpu = 3;  // isolcpus= on the command line, flags before the list
  EXPECT_EQ(check_cpu_isolation(cfg, context).verdict, Verdict::ok);
  cfg.loop.cpu = 1;
  const SetupItem shared = check_cpu_isolation(cfg, context);
  EXPECT_EQ(shared.verdict, Verdict::warning);
  EXPECT_NE(shared.fix.find("isolcpus=1 nohz_full=1"), std::string::npos) << shared.fix;
  cfg.loop.cpu = 7;
  EXPECT_EQ(check_cpu_isolation(cfg, context).verdict, Verdict::fail);
}

TEST_F(FakeHost, DmaLatencyForTheServiceUser) {
  file("dev/cpu_dma_latency", "", fs::perms(0600));
  const SetupItem closed = check_dma_latency(facts, context);
  EXPECT_EQ(closed.verdict, Verdict::warning);
  EXPECT_NE(closed.finding.find("user svc may not read and write"), std::string::npos) << closed.finding;
  EXPECT_NE(closed.fix.find("70-hapticd-realtime.rules"), std::string::npos);
  fs::permissions(root / "dev/cpu_dma_latency", fs::perms(0660));  // the udev rule: group hapticd, 0660
  EXPECT_EQ(check_dma_latency(facts, context).verdict, Verdict::ok);
  fs::remove(root / "dev/cpu_dma_latency");
  EXPECT_EQ(check_dma_latency(facts, context).verdict, Verdict::warning);
}

const char* const usb_device = R"(
[device]
driver = "usb-hid"
[device.usb-hid]
vendor_id = "0x1209"
product_id = "0x0001"
)";

TEST_F(FakeHost, UsbBoardPresentAccessibleAndItsEndpointsAgainstThePeriod) {
  EXPECT_EQ(named(check_device(config_with(usb_device), facts, context), "device").verdict, Verdict::fail);
  const std::string dev = "sys/bus/usb/devices/1-2/";
  file(dev + "idVendor", "1209\n");
  file(dev + "idProduct", "0001\n");
  file(dev + "busnum", "1\n");
  file(dev + "devnum", "3\n");
  file(dev + "speed", "12\n");
  for (const auto& [ep, direction] : {std::pair{"81", "in"}, std::pair{"01", "out"}}) {
    const std::string e = dev + "1-2:1.0/ep_" + ep + "/";
    file(e + "type", "Interrupt\n");
    file(e + "direction", std::string(direction) + "\n");
    file(e + "bEndpointAddress", std::string(ep) + "\n");
    file(e + "wMaxPacketSize", "0040\n");
    file(e + "bInterval", "01\n");
  }
  file("dev/bus/usb/001/003", "", fs::perms(0644));
  auto items = check_device(config_with(usb_device), facts, context);
  EXPECT_EQ(named(items, "device").verdict, Verdict::fail) << named(items, "device").finding;
  EXPECT_NE(named(items, "device").fix.find("70-hapticd-usb-hid.rules"), std::string::npos);
  fs::permissions(root / "dev/bus/usb/001/003", fs::perms(0660));
  items = check_device(config_with(usb_device), facts, context);
  EXPECT_EQ(named(items, "device").verdict, Verdict::ok) << named(items, "device").finding;
  EXPECT_EQ(named(items, "period").verdict, Verdict::ok) << named(items, "period").finding;
  EXPECT_NE(named(items, "period").finding.find("adds 2 periods"), std::string::npos)
      << named(items, "period").finding;
  // A full-speed board polled every 1 ms cannot carry a 500 us period.
  items = check_device(config_with(usb_device, "period = \"500us\""), facts, context);
  EXPECT_EQ(named(items, "period").verdict, Verdict::fail) << named(items, "period").finding;
}

const char* const can_device = R"(
[device]
driver = "canopen"
[device.canopen]
mass = 0.01
counts_per_unit = 16384
interface = "can0"
bitrate = 1000000
)";

TEST_F(FakeHost, CanInterfaceUpAtTheConfiguredBitRateAndTheBusBudget) {
  EXPECT_EQ(named(check_device(config_with(can_device), facts, context), "device").verdict, Verdict::fail);
  file("sys/class/net/can0/type", "280\n");
  file("sys/class/net/can0/flags", "0x80\n");
  const SetupItem down = named(check_device(config_with(can_device), facts, context), "device");
  EXPECT_EQ(down.verdict, Verdict::fail);
  EXPECT_NE(down.finding.find("can0 is down"), std::string::npos) << down.finding;
  EXPECT_NE(down.fix.find("80-hapticd-can.network"), std::string::npos) << down.fix;
  file("sys/class/net/can0/flags", "0xc1\n");
  std::uint32_t rate = 500000;
  context.ip_details = [&rate](const std::string& name) -> std::optional<std::string> {
    if (name != "can0") return std::nullopt;
    return R"([{"ifname":"can0","linkinfo":{"info_kind":"can","info_data":{"bittiming":{"bitrate":)" +
           std::to_string(rate) + "}}}}]";
  };
  const SetupItem slow = named(check_device(config_with(can_device), facts, context), "device");
  EXPECT_EQ(slow.verdict, Verdict::fail);
  EXPECT_NE(slow.finding.find("runs at 500 kbit/s"), std::string::npos) << slow.finding;
  rate = 1000000;
  auto items = check_device(config_with(can_device), facts, context);
  EXPECT_EQ(named(items, "device").verdict, Verdict::ok) << named(items, "device").finding;
  EXPECT_EQ(named(items, "period").verdict, Verdict::ok) << named(items, "period").finding;
  // The bus cannot carry SYNC, RPDO and TPDO every 100 us at 1 Mbit/s.
  items = check_device(config_with(can_device, "period = \"100us\""), facts, context);
  EXPECT_EQ(named(items, "period").verdict, Verdict::fail) << named(items, "period").finding;
  context.ip_details = nullptr;
  EXPECT_EQ(named(check_device(config_with(can_device), facts, context), "device").verdict, Verdict::warning);
}

TEST_F(FakeHost, CanUnixSeamIsTheSocketPath) {
  const std::string cfg =
      "[device]\ndriver = \"canopen\"\n[device.canopen]\nmass = 0.01\ncounts_per_unit = 16384\n"
      "interface = \"unix:" +
      (root / "bus.sock").string() + "\"\n";
  const SetupItem missing = named(check_device(config_with(cfg), facts, context), "device");
  EXPECT_EQ(missing.verdict, Verdict::fail);
  EXPECT_NE(missing.fix.find("hapticd-devsim canopen --listen"), std::string::npos) << missing.fix;
}

TEST_F(FakeHost, ModbusRtuBudgetAndTcpAddress) {
  const auto rtu = config_with(
      "[device]\ndriver = \"modbus\"\n[device.modbus]\ntransport = \"rtu\"\ndevice = \"/dev/ttyUSB0\"\n"
      "baud = 9600\n");
  auto items = check_device(rtu, facts, context);
  EXPECT_EQ(named(items, "device").verdict, Verdict::fail);  // no such port in the fake /dev
  EXPECT_EQ(named(items, "period").verdict, Verdict::fail) << named(items, "period").finding;
  EXPECT_NE(named(items, "period").fix.find("a period of at least"), std::string::npos);
  const auto tcp = config_with("[device]\ndriver = \"modbus\"\n[device.modbus]\nhost = \"127.0.0.1\"\n");
  EXPECT_EQ(named(check_device(tcp, facts, context), "device").verdict, Verdict::ok);
  const auto bad =
      config_with("[device]\ndriver = \"modbus\"\n[device.modbus]\nhost = \"no such host.invalid\"\n");
  EXPECT_EQ(named(check_device(bad, facts, context), "device").verdict, Verdict::fail);
}

TEST_F(FakeHost, GpioChipAndPwmExportForTheServiceUser) {
  const std::string cfg = std::string("[device]\ndriver = \"gpio-pwm\"\n[device.gpio-pwm]\nmass = 0.0005\n") +
                          "enable_line = \"1\"\ndirection_line = \"2\"\nforce_at_full_duty = 0.6\n";
  file("dev/gpiochip0", "", fs::perms(0600));
  file("sys/class/pwm/pwmchip0/npwm", "2\n");
  file("sys/class/pwm/pwmchip0/export", "", fs::perms(0200));
  auto items = check_device(config_with(cfg), facts, context);
  EXPECT_EQ(named(items, "device").verdict, Verdict::fail);
  EXPECT_EQ(named(items, "pwm").verdict, Verdict::fail);
  EXPECT_NE(named(items, "pwm").fix.find("70-hapticd-gpio-pwm.rules"), std::string::npos);
  // What the udev rules do: the chip 0660 to group hapticd, export g+w.
  fs::permissions(root / "dev/gpiochip0", fs::perms(0660));
  fs::permissions(root / "sys/class/pwm/pwmchip0/export", fs::perms(0220));
  items = check_device(config_with(cfg), facts, context);
  EXPECT_EQ(named(items, "device").verdict, Verdict::ok) << named(items, "device").finding;
  EXPECT_EQ(named(items, "pwm").verdict, Verdict::ok) << named(items, "pwm").finding;
  items = check_device(config_with(cfg + "pwm_channel = 2\n"), facts, context);
  EXPECT_EQ(named(items, "pwm").verdict, Verdict::fail) << named(items, "pwm").finding;
}

TEST_F(FakeHost, TheWholeRunItsVerdictAndJson) {
  const DaemonConfig cfg = default_config();
  facts.cap_sys_nice = facts.cap_ipc_lock = true;
  const auto items = run_setup_check(cfg, facts, context);
  std::vector<std::string> names;
  names.reserve(items.size());
  for (const auto& i : items) names.push_back(i.name);
  EXPECT_EQ(names, (std::vector<std::string>{"rt-priority", "memlock", "kernel", "cpu-isolation",
                                             "cpu-dma-latency", "device", "period", "paths"}));
  EXPECT_EQ(overall(items), Verdict::warning);  // no PREEMPT_RT, no isolation, no cpu_dma_latency here
  const auto j = to_json(cfg, facts, items);
  EXPECT_EQ(j["verdict"], "warning");
  EXPECT_EQ(j["items"].size(), items.size());
  EXPECT_EQ(j["counts"]["ok"].get<int>() + j["counts"]["warning"].get<int>() + j["counts"]["fail"].get<int>(),
            static_cast<int>(items.size()));
  std::vector<SetupItem> failed = items;
  failed.push_back({"x", Verdict::fail, "f", "fix"});
  EXPECT_EQ(overall(failed), Verdict::fail);
  EXPECT_NE(to_text(cfg, facts, failed).find("1 failures"), std::string::npos);
}

}  // namespace
}  // namespace hapticd::daemon::config::setup_check_test
