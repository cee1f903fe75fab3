#include "daemon/system/systemd_notify.hpp"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>

namespace systemd_notify_test {

using hapticd::daemon::system::SystemdNotifier;

namespace {

// Restores an environment variable at scope exit.
class EnvVar {
 public:
  EnvVar(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old, had_ = true;
    if (value)
      ::setenv(name, value, 1);
    else
      ::unsetenv(name);
  }
  ~EnvVar() {
    if (had_)
      ::setenv(name_, old_.c_str(), 1);
    else
      ::unsetenv(name_);
  }

 private:
  const char* name_;
  std::string old_;
  bool had_ = false;
};

std::string receive(int fd) {
  char buf[512];
  const ssize_t n = ::recv(fd, buf, sizeof buf, MSG_DONTWAIT);
  return n > 0 ? std::string(buf, static_cast<std::size_t>(n)) : std::string();
}

}  // namespace

TEST(SystemdNotifier, NoOpWithoutNotifySocket) {
  EnvVar sock("NOTIFY_SOCKET", nullptr);
  EnvVar wd("WATCHDOG_USEC", nullptr);
  SystemdNotifier n;
  EXPECT_FALSE(n.enabled());
  EXPECT_FALSE(n.watchdog_interval().has_value());
  EXPECT_FALSE(n.ready());
  EXPECT_FALSE(n.status("hello"));
  EXPECT_FALSE(n.watchdog_ping());
}

TEST(SystemdNotifier, SendsToTheNotifySocketAndReadsTheWatchdog) {
  const std::string path =
      (std::filesystem::temp_directory_path() / ("hapticd_notify_" + std::to_string(::getpid()))).string();
  ::unlink(path.c_str());
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  ASSERT_GE(fd, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0) << std::strerror(errno);

  EnvVar sock("NOTIFY_SOCKET", path.c_str());
  EnvVar wd("WATCHDOG_USEC", "2000000");
  EnvVar pid("WATCHDOG_PID", std::to_string(::getpid()).c_str());
  SystemdNotifier n;
  EXPECT_TRUE(n.enabled());
  ASSERT_TRUE(n.watchdog_interval().has_value());
  EXPECT_EQ(n.watchdog_interval()->count(), 2'000'000);

  EXPECT_TRUE(n.ready());
  EXPECT_EQ(receive(fd), "READY=1");
  EXPECT_TRUE(n.status("running spring-wheel\nat 1 kHz"));
  EXPECT_EQ(receive(fd), "STATUS=running spring-wheel at 1 kHz");
  EXPECT_TRUE(n.watchdog_ping());
  EXPECT_EQ(receive(fd), "WATCHDOG=1");
  EXPECT_TRUE(n.stopping());
  EXPECT_EQ(receive(fd), "STOPPING=1");
  ::close(fd);
  ::unlink(path.c_str());
}

}  // namespace systemd_notify_test
