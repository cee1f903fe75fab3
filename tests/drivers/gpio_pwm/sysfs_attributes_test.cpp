// The PWM and counter transport against the simulated board's sysfs files
// (real paths under a temporary root; the device tests use the same files
// through the umockdev testbed's /sys). The simulated chip replays every
// write through the kernel's rules and records what the kernel would refuse.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

#include "drivers/gpio_pwm/sysfs_attributes.hpp"
#include "drivers/stop_request.hpp"
#include "sim/gpio_pwm/sysfs_peripherals.hpp"
#include "tests/support/alloc_counter.hpp"

namespace hapticd::drivers::gpio_pwm::sysfs_attributes_test {
namespace {

namespace fs = std::filesystem;

// On tmpfs when there is one: the simulated attributes are rewritten on
// every store, which costs milliseconds on a journaling disk.
class TempRoot {
 public:
  TempRoot() {
    std::string pattern =
        fs::is_directory("/dev/shm") ? "/dev/shm/hapticd-sysfs.XXXXXX" : "/tmp/hapticd-sysfs.XXXXXX";
    path_ = ::mkdtemp(pattern.data());
  }
  ~TempRoot() { fs::remove_all(path_); }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

constexpr const char* pwm_chip_path = "/sys/class/pwm/pwmchip0";

std::string describe(const std::vector<sim::RefusedWrite>& refused) {
  std::string s;
  for (const auto& r : refused) s += r.attribute + " <- " + r.text + " : " + std::strerror(r.error) + "; ";
  return s;
}

PwmOutput::Settings settings(const TempRoot& root, std::uint64_t period = 50'000, bool inversed = false) {
  return {root.path() + pwm_chip_path, 0, period, inversed, 1.0};
}

TEST(PwmOutput, ExportsAFreshChannelAndLeavesItEnabledAtDutyZero) {
  TempRoot root;
  sim::SimulatedPwmChip chip(root.path(), pwm_chip_path, 2);
  ASSERT_FALSE(chip.exported(0));
  PwmOutput pwm(settings(root));
  EXPECT_TRUE(chip.exported(0));
  EXPECT_EQ(chip.state(0), (sim::PwmChannelState{50'000, 0, true, false}));
  EXPECT_EQ(pwm.timing(), (PwmTiming{50'000, 0}));
  EXPECT_TRUE(chip.refused().empty()) << describe(chip.refused());
}

TEST(PwmOutput, TakesOverAChannelLeftRunning) {
  TempRoot root;
  sim::SimulatedPwmChip chip(root.path(), pwm_chip_path, 1, {0}, {20'000, 15'000, true, false});
  PwmOutput pwm(settings(root, 10'000));  // shrinking below the running duty: duty first
  EXPECT_EQ(chip.state(0), (sim::PwmChannelState{10'000, 0, true, false}));
  EXPECT_TRUE(chip.refused().empty()) << describe(chip.refused());
}

TEST(PwmOutput, ChangesPolarityOnlyWhileDisabledAndAfterAPeriod) {
  TempRoot root;
  {
    sim::SimulatedPwmChip running(root.path(), pwm_chip_path, 1, {0}, {20'000, 15'000, true, false});
    PwmOutput pwm(settings(root, 50'000, true));
    EXPECT_EQ(running.state(0), (sim::PwmChannelState{50'000, 0, true, true}));
    EXPECT_TRUE(running.refused().empty()) << describe(running.refused());
  }
  TempRoot fresh_root;
  sim::SimulatedPwmChip fresh(fresh_root.path(), pwm_chip_path, 1,
                              {0});  // period 0: polarity alone is EINVAL
  PwmOutput pwm(settings(fresh_root, 50'000, true));
  EXPECT_EQ(fresh.state(0), (sim::PwmChannelState{50'000, 0, true, true}));
  EXPECT_TRUE(fresh.refused().empty()) << describe(fresh.refused());
}

TEST(PwmOutput, DutyWritesOnlyWhenChangedAndNeverRefused) {
  TempRoot root;
  sim::SimulatedPwmChip chip(root.path(), pwm_chip_path, 1);
  PwmOutput pwm(settings(root));
  const std::uint64_t before = pwm.writes();
  std::mt19937 rng(7);
  std::uniform_int_distribution<std::uint64_t> duty(0, 50'000);
  std::uint64_t last = 0, changes = 0;
  for (int i = 0; i < 200; ++i) {
    const std::uint64_t d = i % 3 == 0 ? last : duty(rng);
    changes += d != last;
    ASSERT_EQ(pwm.set_duty(d), 0);
    last = d;
  }
  EXPECT_EQ(pwm.writes() - before, changes);
  EXPECT_EQ(chip.state(0).duty_ns, last);
  // Period changes both ways, duty kept within each.
  for (const PwmTiming t :
       {PwmTiming{100'000, 90'000}, PwmTiming{20'000, 5'000}, PwmTiming{40'000, 40'000}}) {
    ASSERT_EQ(pwm.set_timing(t), 0);
    EXPECT_EQ(chip.state(0), (sim::PwmChannelState{t.period_ns, t.duty_ns, true, false}));
  }
  EXPECT_EQ(pwm.set_duty(40'001), EINVAL);  // refused before any write: above the period
  EXPECT_TRUE(chip.refused().empty()) << describe(chip.refused());
}

// The driver's side only: plain attribute files, no simulated store (which
// allocates: it is the simulated kernel).
TEST(PwmOutput, SetDutyDoesNotAllocate) {
  TempRoot root;
  const std::string channel = root.path() + pwm_chip_path + "/pwm0";
  fs::create_directories(channel);
  std::ofstream(root.path() + pwm_chip_path + "/npwm") << "1\n";
  for (const char* a : {"period", "duty_cycle", "enable"}) std::ofstream(channel + "/" + a) << "0\n";
  std::ofstream(channel + "/polarity") << "normal\n";
  PwmOutput pwm(settings(root));
  int failed = 0;
  testing::AllocationGuard guard;
  for (std::uint64_t i = 0; i < 1000; ++i) failed += pwm.set_duty((i * 37) % 50'000) != 0;
  const auto allocations = guard.count();
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(failed, 0) << "set_duty() calls that failed";
}

// The simulated store runs on the writer's thread (the RT thread in the
// device tests): an accepted write must not allocate there either.
TEST(PwmOutput, SimulatedStoreDoesNotAllocateOnTheWritersThread) {
  TempRoot root;
  sim::SimulatedPwmChip chip(root.path(), pwm_chip_path, 1);
  PwmOutput pwm(settings(root));
  testing::AllocationGuard guard;
  for (std::uint64_t i = 0; i < 1000; ++i) pwm.set_duty((i * 37) % 50'000);
  const auto allocations = guard.count();
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(chip.state(0).duty_ns, (999u * 37) % 50'000);
}

// The simulated kernel refuses a wrong order with the kernel's errno, so
// the tests above can fail, and a driver sees what it would see on a chip.
TEST(PwmOutput, SimulatedChipRefusesWhatTheKernelRefuses) {
  TempRoot root;
  sim::SimulatedPwmChip chip(root.path(), pwm_chip_path, 1, {0}, {50'000, 0, true, false});
  const SysfsAttribute duty(chip.chip_dir() + "/pwm0/duty_cycle", true, "test");
  EXPECT_EQ(duty.write_u64(60'000), EINVAL);
  const auto refused = chip.refused();
  ASSERT_EQ(refused.size(), 1u);
  EXPECT_EQ(refused[0].attribute, "duty_cycle");
  EXPECT_EQ(refused[0].text, "60000\n");
  std::uint64_t now = 1;
  ASSERT_EQ(duty.read_u64(now), 0);
  EXPECT_EQ(now, 0u);  // unchanged, as the kernel keeps it
  const SysfsAttribute polarity(chip.chip_dir() + "/pwm0/polarity", true, "test");
  EXPECT_EQ(polarity.write_text("inversed\n"), EBUSY);
  EXPECT_EQ(duty.write_u64(25'000), 0);
  EXPECT_EQ(chip.state(0).duty_ns, 25'000u);
}

TEST(PwmOutput, ErrorsNameTheKey) {
  TempRoot root;
  try {
    PwmOutput pwm(settings(root));
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.key(), "pwm_chip");
  }
  sim::SimulatedPwmChip chip(root.path(), pwm_chip_path, 2);
  auto s = settings(root);
  s.channel = 2;
  try {
    PwmOutput pwm(s);
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.key(), "pwm_channel");
    EXPECT_NE(std::string(e.what()).find("accepted: 0 to 1"), std::string::npos) << e.what();
  }
}

TEST(PwmOutput, ExportThatNeverAppearsTimesOut) {
  TempRoot root;
  const std::string chip = root.path() + pwm_chip_path;
  fs::create_directories(chip);
  std::ofstream(chip + "/npwm") << "1\n";
  std::ofstream(chip + "/export") << "";
  auto s = settings(root);
  s.export_timeout_s = 0.05;
  try {
    PwmOutput pwm(s);
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.key(), "export_timeout");
  }
}

// Issue 17 item 9: the wait for the exported channel (export_timeout, up to
// 10 s) gives way to the daemon's stop.
TEST(PwmOutput, TheExportWaitGivesWayToAStop) {
  TempRoot root;
  const std::string chip = root.path() + pwm_chip_path;
  fs::create_directories(chip);
  std::ofstream(chip + "/npwm") << "1\n";
  std::ofstream(chip + "/export") << "";
  auto s = settings(root);
  s.export_timeout_s = 10.0;
  StopRequest stop;
  stop.request("the test");
  s.stop = stop.token();
  try {
    PwmOutput pwm(s);
    FAIL();
  } catch (const StopRequested& e) {
    EXPECT_NE(std::string(e.what()).find("after the export: abandoned, hapticd is stopping"),
              std::string::npos)
        << e.what();
  } catch (const TransportError& e) {
    FAIL() << "waited the whole export_timeout: " << e.what();
  }
}

TEST(CounterInput, ReadsCountCeilingAndFunction) {
  TempRoot root;
  sim::SimulatedCounter counter(root.path(), "/sys/bus/counter/devices/counter0", 0, 0xFFFFFFFF);
  counter.set_position(-5);
  CounterInput input(root.path() + "/sys/bus/counter/devices/counter0", 0);
  EXPECT_EQ(input.ceiling(), 0xFFFFFFFFu);
  EXPECT_EQ(input.function(), "quadrature x4");
  std::uint64_t raw = 0;
  ASSERT_EQ(input.read(raw), 0);
  EXPECT_EQ(raw, 0xFFFFFFFBu);
  counter.set_position(12345);
  testing::AllocationGuard guard;
  for (int i = 0; i < 1000; ++i) input.read(raw);
  const auto allocations = guard.count();
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(raw, 12345u);
}

TEST(CounterInput, ErrorsNameTheKey) {
  TempRoot root;
  try {
    CounterInput input(root.path() + "/sys/bus/counter/devices/counter0", 0);
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.key(), "counter");
  }
  sim::SimulatedCounter counter(root.path(), "/sys/bus/counter/devices/counter0", 0, 1000);
  try {
    CounterInput input(root.path() + "/sys/bus/counter/devices/counter0", 1);
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.key(), "counter_count");
  }
  std::ofstream(counter.count_path()) << "garbage\n";
  try {
    CounterInput input(root.path() + "/sys/bus/counter/devices/counter0", 0);
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.key(), "counter");
    EXPECT_EQ(e.error_code(), EBADMSG);
  }
}

}  // namespace
}  // namespace hapticd::drivers::gpio_pwm::sysfs_attributes_test
