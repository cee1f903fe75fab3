// The testbed and its ioctl handler in this process, libusb in another one:
// what the end-to-end test needs to run the real hapticd against the board.
// The handler resolves every URB afresh from the client's memory at reap
// (sim/umockdev_board.cpp), so the child's URBs come back filled in.

#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "drivers/usb_hid/report_codec.hpp"
#include "emulated_board_fixture.hpp"

extern char** environ;

namespace hapticd::drivers::usb_hid::cross_process_test {
namespace {

using testing::EmulatedBoardTest;

/// Runs `argv` with LD_PRELOAD=libumockdev-preload.so.0 (UMOCKDEV_DIR is
/// already in this process's environment: umockdev_testbed_new sets it).
int run_preloaded(const std::vector<std::string>& argv, std::string& output) {
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) return -1;
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_addclose(&actions, pipe_fds[0]);
  std::vector<std::string> env_strings{"LD_PRELOAD=libumockdev-preload.so.0"};
  for (char** e = environ; *e != nullptr; ++e)
    if (std::string(*e).rfind("LD_PRELOAD=", 0) != 0) env_strings.emplace_back(*e);
  std::vector<char*> env, args;
  for (auto& s : env_strings) env.push_back(s.data());
  env.push_back(nullptr);
  std::vector<std::string> argv_copy = argv;
  for (auto& s : argv_copy) args.push_back(s.data());
  args.push_back(nullptr);
  pid_t pid = 0;
  const int spawned = posix_spawn(&pid, args[0], &actions, nullptr, args.data(), env.data());
  posix_spawn_file_actions_destroy(&actions);
  close(pipe_fds[1]);
  if (spawned != 0) {
    close(pipe_fds[0]);
    return -1;
  }
  std::array<char, 256> buffer;
  ssize_t n = 0;
  while ((n = read(pipe_fds[0], buffer.data(), buffer.size())) > 0)
    output.append(buffer.data(), static_cast<std::size_t>(n));
  close(pipe_fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST_F(EmulatedBoardTest, AnotherProcessExchangesTwoHundredReports) {
  ASSERT_NE(std::getenv("UMOCKDEV_DIR"), nullptr);
  EXPECT_EQ(std::string(std::getenv("UMOCKDEV_DIR")), testbed->root_dir());
  std::string output;
  ASSERT_EQ(run_preloaded({USB_HID_PROBE, "200"}, output), 0) << output;
  EXPECT_EQ(
      output,
      "periods=200 ok=200 in=201 out=200 board=1209:0001 serial SIM0001 at 1-2, full speed (12 Mbit/s)\n");
  const auto s = board->snapshot();
  EXPECT_EQ(s.firmware.out_reports, 200U);
  // Built: the power-on report, the fresh one for the new host at claim
  // (it replaces the first, unsent), then one per OUT report.
  EXPECT_EQ(s.firmware.in_reports, 202U);
  // The child's commands 0..199 reached the plant, in order.
  ASSERT_EQ(plant->forces().size(), 200U);
  for (std::size_t p = 0; p < 200; ++p)
    EXPECT_DOUBLE_EQ(plant->forces()[p], command_force(static_cast<std::int64_t>(p),
                                                       scaling.command_full_scale, OutLayout{}.command[0]))
        << p;
  const auto c = testbed->counters();
  EXPECT_FALSE(c.claimed) << "released when the child closed";
  EXPECT_TRUE(c.kernel_driver_bound) << "and the kernel driver re-attached";
}

}  // namespace
}  // namespace hapticd::drivers::usb_hid::cross_process_test
