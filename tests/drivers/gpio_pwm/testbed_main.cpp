// main() of the tests that run libgpiod against the umockdev testbed: the
// preload must be in the process from its start, so the program re-executes
// itself with LD_PRELOAD=libumockdev-preload.so.0 when run without it (by
// ctest's test discovery or by hand).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "sim/gpio_pwm/umockdev_gpio_testbed.hpp"

int main(int argc, char** argv) {
  // Not loaded is a failure, never a skip: the build links umockdev, so its
  // absence at run time is a broken install (the reason is on stderr).
  if (!hapticd::drivers::gpio_pwm::sim::ensure_umockdev_preload(argc, argv)) return 1;
  // The testbed's files on tmpfs: the simulated attributes are rewritten on
  // every store, which costs milliseconds each on a journaling disk.
  if (std::getenv("TMPDIR") == nullptr && std::filesystem::is_directory("/dev/shm"))
    ::setenv("TMPDIR", "/dev/shm", 1);
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
