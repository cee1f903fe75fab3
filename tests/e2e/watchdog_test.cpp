// End-to-end: the systemd watchdog, against a fake notify socket that does
// what systemd does with the unit's own settings (WatchdogSec=, Restart=):
// it checks READY=1 and the WATCHDOG=1 cadence while the loop runs; when
// the RT thread stops advancing (stopped here with ptrace, as a thread stuck
// in a driver call would be) the pings must stop while the control thread
// still answers; the fake then kills the daemon with the watchdog signal and
// starts it again, as Restart=on-failure does, and the new one pings.

#include <gtest/gtest.h>

#include <signal.h>
#include <sys/ptrace.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "support.hpp"

namespace hapticd::e2e::watchdog_test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

/// The notify socket systemd would hold: every datagram with its arrival time.
class FakeNotifySocket {
 public:
  explicit FakeNotifySocket(const fs::path& path) : path_(path) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::strncpy(addr.sun_path, path.c_str(), sizeof addr.sun_path - 1);
    if (fd_ < 0 || ::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0)
      throw std::runtime_error("cannot bind " + path.string());
    timeval tv{0, 50'000};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    thread_ = std::thread([this] {
      char buf[4096];
      while (!stop_) {
        const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
        if (n <= 0) continue;
        std::lock_guard lock(mutex_);
        messages_.push_back({Clock::now(), std::string(buf, static_cast<std::size_t>(n))});
      }
    });
  }
  ~FakeNotifySocket() {
    stop_ = true;
    thread_.join();
    ::close(fd_);
  }
  FakeNotifySocket(const FakeNotifySocket&) = delete;
  FakeNotifySocket& operator=(const FakeNotifySocket&) = delete;

  /// Arrival times of messages equal to `text` after `since`.
  std::vector<Clock::time_point> times_of(const std::string& text, Clock::time_point since = {}) const {
    std::lock_guard lock(mutex_);
    std::vector<Clock::time_point> out;
    for (const auto& m : messages_) {
      if (m.text == text && m.at >= since) out.push_back(m.at);
    }
    return out;
  }
  const fs::path& path() const { return path_; }

 private:
  struct Message {
    Clock::time_point at;
    std::string text;
  };
  fs::path path_;
  int fd_ = -1;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::vector<Message> messages_;
  std::thread thread_;
};

/// WatchdogSec= and Restart= of the generated unit, as systemd reads them.
struct UnitWatchdog {
  std::chrono::milliseconds watchdog{0};
  std::string restart;
};
UnitWatchdog unit_settings() {
  std::ifstream in(fs::path(HAPTICD_BINARY_DIR) / "systemd" / "hapticd.service");
  UnitWatchdog u;
  std::smatch m;
  for (std::string line; std::getline(in, line);) {
    if (std::regex_match(line, m, std::regex(R"(WatchdogSec=([0-9.]+)(ms|s)?)")))
      u.watchdog = std::chrono::milliseconds(
          static_cast<std::int64_t>(std::stod(m[1].str()) * (m[2].str() == "ms" ? 1 : 1000)));
    if (std::regex_match(line, m, std::regex(R"(Restart=(\S+))"))) u.restart = m[1].str();
  }
  return u;
}

/// The thread of `pid` called `name` (/proc/PID/task/*/comm), or -1.
pid_t thread_named(pid_t pid, const std::string& name) {
  const fs::path tasks = fs::path("/proc") / std::to_string(pid) / "task";
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(tasks, ec)) {
    std::ifstream comm(entry.path() / "comm");
    std::string text;
    std::getline(comm, text);
    if (text == name) return static_cast<pid_t>(std::stoi(entry.path().filename().string()));
  }
  return -1;
}

std::uint64_t cycle_of(const Daemon& d) {
  const auto r = d.ctl({"status", "--json"});
  return r.exit_code == 0 ? json::parse(r.out).value("cycle", std::uint64_t{0}) : 0;
}

double seconds(Clock::duration d) { return std::chrono::duration<double>(d).count(); }

constexpr const char* config = R"(
[loop]
period = "1ms"
clock = "real"
overrun_limit = 0
[device]
driver = "loopback"
[scene]
name = "spring-wheel"
)";

TEST(SystemdWatchdog, PingsOnlyWhileTheLoopAdvancesAndTheUnitRestartsAStalledDaemon) {
  const UnitWatchdog unit = unit_settings();
  ASSERT_GT(unit.watchdog.count(), 0) << "the unit has no WatchdogSec=";
  ASSERT_TRUE(unit.restart == "on-failure" || unit.restart == "on-watchdog" || unit.restart == "always")
      << "Restart=" << unit.restart << " would not restart a daemon the watchdog killed";
  // No core file from the watchdog's SIGABRT (children inherit the limit).
  rlimit no_core{0, 0};
  setrlimit(RLIMIT_CORE, &no_core);

  TempDir dir;
  FakeNotifySocket notify(dir.path / "notify.sock");
  const std::string usec = std::to_string(std::chrono::microseconds(unit.watchdog).count());
  const std::vector<std::string> as_systemd{"/usr/bin/env", "NOTIFY_SOCKET=" + notify.path().string(),
                                            "WATCHDOG_USEC=" + usec};
  auto d = std::make_unique<Daemon>(dir, config, std::vector<std::string>{}, as_systemd);
  ASSERT_TRUE(d->running()) << d->log();
  const auto started = Clock::now();
  std::this_thread::sleep_for(unit.watchdog * 2);
  ASSERT_EQ(notify.times_of("READY=1").size(), 1u);

  // Running: pings at about half the interval, never a gap systemd would
  // take for a hang.
  const auto pings = notify.times_of("WATCHDOG=1");
  ASSERT_GE(pings.size(), 3u) << "pings in " << seconds(Clock::now() - started) << " s";
  for (std::size_t i = 1; i < pings.size(); ++i) {
    EXPECT_LT(pings[i] - pings[i - 1], unit.watchdog) << "gap " << seconds(pings[i] - pings[i - 1]) << " s";
  }

  // The RT thread stops advancing (ptrace-stopped, the rest of the daemon runs on).
  const pid_t rt = thread_named(d->pid(), "hapticd-rt");
  ASSERT_GT(rt, 0) << "no thread named hapticd-rt";
  if (::ptrace(PTRACE_SEIZE, rt, nullptr, nullptr) != 0)
    GTEST_SKIP() << "cannot ptrace the RT thread here: " << std::strerror(errno);
  ASSERT_EQ(::ptrace(PTRACE_INTERRUPT, rt, nullptr, nullptr), 0) << std::strerror(errno);
  int wstatus = 0;
  ASSERT_EQ(::waitpid(rt, &wstatus, __WALL), rt);
  const auto stalled = Clock::now();
  const std::uint64_t frozen = cycle_of(*d);
  ASSERT_GT(frozen, 0u) << "the control thread must still answer";

  // systemd's view: the last ping, and no ping for WatchdogSec after it.
  Clock::time_point last = pings.back();
  while (Clock::now() - last < unit.watchdog) {
    std::this_thread::sleep_for(20ms);
    const auto more = notify.times_of("WATCHDOG=1", last + 1ns);
    if (!more.empty()) last = more.back();
    ASSERT_LT(Clock::now() - stalled, 4 * unit.watchdog) << "still pinging with the loop stopped";
  }
  // At most one check after the stall could still see the loop's last cycles.
  EXPECT_LE(last - stalled, unit.watchdog / 2 + 200ms)
      << "pinged " << seconds(last - stalled) << " s after the stall";
  EXPECT_EQ(cycle_of(*d), frozen) << "the loop advanced while stopped?";
  EXPECT_TRUE(d->running());

  // The watchdog fires: systemd sends WatchdogSignal= (SIGABRT by default)
  // and, the service having failed, Restart= starts it again.
  ASSERT_EQ(::kill(d->pid(), SIGABRT), 0);
  // We trace the RT thread: its end is ours to reap before the process's
  // exit is reported to its parent.
  for (const auto give_up = Clock::now() + 10s; Clock::now() < give_up;) {
    if (::waitpid(rt, &wstatus, __WALL | WNOHANG) == rt && (WIFEXITED(wstatus) || WIFSIGNALED(wstatus)))
      break;
    std::this_thread::sleep_for(10ms);
  }
  const int status = d->wait(10s);
  EXPECT_EQ(status, -SIGABRT) << d->log();
  d.reset();

  const auto restarted = Clock::now();
  auto again = std::make_unique<Daemon>(dir, config, std::vector<std::string>{}, as_systemd);
  ASSERT_TRUE(again->running()) << again->log();
  std::this_thread::sleep_for(unit.watchdog * 3 / 2);
  EXPECT_EQ(notify.times_of("READY=1", restarted).size(), 1u);
  EXPECT_GE(notify.times_of("WATCHDOG=1", restarted).size(), 2u) << "the restarted daemon does not ping";
  EXPECT_EQ(again->stop(), 0) << again->log();
  EXPECT_GE(notify.times_of("STOPPING=1", restarted).size(), 1u);
}

}  // namespace
}  // namespace hapticd::e2e::watchdog_test
