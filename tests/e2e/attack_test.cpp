// End-to-end: the control-plane attacks of issue 6, replayed against the real
// hapticd: a request nested 60,000 levels deep, a client pipelining requests
// while others (and an estop) wait, readers holding every connection slot,
// and a stream rate that used to become a 1 ns timer.

#include <gtest/gtest.h>

#include <grp.h>
#include <poll.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstring>
#include <deque>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "support.hpp"

namespace hapticd::e2e::attack_test {
namespace {

using nlohmann::json;
using namespace std::chrono_literals;

// A linear loopback on the real clock with no force; overruns never latch a
// fault (the VM is noisy).
std::string device_config(const std::string& control = "") {
  return R"(
[loop]
period = "1ms"
clock = "real"
overrun_limit = 0

[device]
driver = "loopback"
torque_limit = 20.0

[device.loopback]
motion = "linear"
mass = 0.1

[scene]
name = "free"
)" + control;
}

std::string control_section(const TempDir& dir, const std::string& extra) {
  return "\n[control]\nsocket = \"" + (dir.path / "hapticd.sock").string() + "\"\n" + extra + "\n";
}

/// The reply to `line` sent on a fresh connection.
json ask(const Daemon& d, const std::string& line) {
  RawConnection c(d.socket());
  EXPECT_TRUE(c.send(line + "\n"));
  const std::string reply = c.read_line();
  return reply.empty() ? json() : json::parse(reply, nullptr, false);
}

std::string nested(std::size_t levels) { return std::string(levels, '[') + std::string(levels, ']'); }

/// Runs `f` with the soft stack limit set to `bytes` (children inherit it).
template <typename F>
auto with_stack_limit(rlim_t bytes, F&& f) {
  rlimit saved{};
  getrlimit(RLIMIT_STACK, &saved);
  rlimit lowered = saved;
  lowered.rlim_cur = bytes;
  setrlimit(RLIMIT_STACK, &lowered);
  struct Restore {
    rlimit limit;
    ~Restore() { setrlimit(RLIMIT_STACK, &limit); }
  } restore{saved};
  return f();
}

// Issue 6, defect 1: param.get with `names` nested 60,000 levels deep killed
// hapticd with SIGSEGV (max_message_bytes 1 MiB; with the default 64 KiB,
// under a 4 MiB stack limit). Now -32600 naming the limit, and it runs on.
TEST(Attack, DeeplyNestedRequestIsRefusedAndTheDaemonRunsOn) {
  struct Case {
    std::string control;
    std::size_t levels;
    rlim_t stack;
  };
  for (const Case& attack :
       {Case{"max_message_bytes = 1048576", 60000, 8u << 20}, Case{"", 32000, 4u << 20}}) {
    TempDir dir;
    auto d = with_stack_limit(attack.stack, [&] {
      return std::make_unique<Daemon>(dir, device_config(control_section(dir, attack.control)));
    });
    ASSERT_TRUE(d->running()) << d->log();
    const json reply = ask(*d, R"({"jsonrpc":"2.0","id":7,"method":"param.get","params":{"names":)" +
                                   nested(attack.levels) + "}}");
    ASSERT_TRUE(reply.is_object()) << "no reply; hapticd's exit status " << d->wait(2s)
                                   << " (-11: SIGSEGV, -2000: still running)\n"
                                   << d->log();
    EXPECT_EQ(reply["error"]["code"], -32600) << reply.dump();
    EXPECT_EQ(reply["error"]["data"]["limit"], 64) << reply.dump();
    EXPECT_NE(reply["error"]["message"].get<std::string>().find("64 levels"), std::string::npos);
    EXPECT_TRUE(d->running()) << d->log();
    const auto status = d->ctl({"status", "--json"});
    EXPECT_EQ(status.exit_code, 0) << status.err;
    EXPECT_EQ(d->stop(), 0) << d->log();
  }
}

/// A client pipelining `scene.list` as fast as the daemon reads, never
/// waiting for a reply (a second thread throws the replies away).
class Flooder {
 public:
  explicit Flooder(const std::filesystem::path& socket) : connection_(socket) {
    writer_ = std::thread([this] {
      std::string burst;
      for (int i = 0; i < 200; ++i)
        burst += R"({"jsonrpc":"2.0","id":1,"method":"scene.list"})"
                 "\n";
      while (!stop_ && connection_.send(burst)) {
      }
    });
    reader_ = std::thread([this] {
      while (!stop_ && !connection_.read_line(1s).empty()) ++replies_;
    });
  }
  ~Flooder() {
    stop_ = true;
    ::shutdown(connection_.fd(), SHUT_RDWR);
    writer_.join();
    reader_.join();
  }
  Flooder(const Flooder&) = delete;
  Flooder& operator=(const Flooder&) = delete;
  int replies() const { return replies_; }

 private:
  RawConnection connection_;
  std::atomic<bool> stop_{false};
  std::atomic<int> replies_{0};
  std::thread writer_, reader_;
};

/// Wall time from connecting to the reply of `method`, in ms.
double reply_ms(const Daemon& d, const std::string& method) {
  const auto t0 = std::chrono::steady_clock::now();
  RawConnection c(d.socket());
  c.send(R"({"jsonrpc":"2.0","id":1,"method":")" + method + "\"}\n");
  const json reply = json::parse(c.read_line(10s), nullptr, false);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_TRUE(reply.is_object() && reply.contains("result")) << method << ": " << reply.dump();
  return ms;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// Issue 6, defect 2: a client pipelining scene.list delayed every other
// client's replies to ~770 ms (0.24 ms without it), and an estop from
// another connection took 770-820 ms. The bound here is generous (the VM
// stalls); the failure it guards against is seconds.
TEST(Attack, PipeliningClientDelaysNeitherOthersNorEstop) {
  TempDir dir;
  Daemon d(dir, device_config());
  ASSERT_TRUE(d.running()) << d.log();
  Flooder flooder(d.socket());
  const auto t0 = std::chrono::steady_clock::now();
  while (flooder.replies() < 2000 && std::chrono::steady_clock::now() - t0 < 20s)
    std::this_thread::sleep_for(10ms);
  ASSERT_GE(flooder.replies(), 2000) << "the flood did not get going";
  std::vector<double> status_ms, estop_ms;
  for (int i = 0; i < 5; ++i) {
    status_ms.push_back(reply_ms(d, "status"));
    estop_ms.push_back(reply_ms(d, "estop"));
  }
  EXPECT_LT(median(status_ms), 100.0) << "status under the flood";
  EXPECT_LT(median(estop_ms), 100.0) << "estop under the flood";
  // The real hapticctl too (not timed: it includes starting a process).
  const auto estop = d.ctl({"estop"});
  EXPECT_EQ(estop.exit_code, 0) << estop.err;
  EXPECT_EQ(json::parse(d.ctl({"status", "--json"}).out, nullptr, false)["fault"], "estop");
  std::printf("under the flood: status median %.2f ms, estop median %.2f ms\n", median(status_ms),
              median(estop_ms));
}

// Issue 6, defect 2: 16 idle connections from a user outside the group took
// every slot (max_clients) and root's `hapticctl estop` failed with "too
// many clients". A writer now takes the slot of the longest-idle reader.
TEST(Attack, ReadersHoldingEverySlotCannotKeepRootsEstopOut) {
  if (geteuid() != 0) GTEST_SKIP() << "needs root to hold the slots as nobody";
  TempDir dir;
  Daemon d(dir, device_config());
  ASSERT_TRUE(d.running()) << d.log();
  chmod(dir.path.c_str(), 0755);    // nobody must reach the socket...
  chmod(d.socket().c_str(), 0666);  // ...and connect (read access only)
  int ready[2];
  ASSERT_EQ(pipe(ready), 0);
  const pid_t pid = fork();
  if (pid == 0) {
    close(ready[0]);
    if (setgroups(0, nullptr) != 0 || setgid(65534) != 0 || setuid(65534) != 0) _exit(121);
    std::vector<std::unique_ptr<RawConnection>> held;
    for (int i = 0; i < 20; ++i) {  // more than max_clients: the extra ones are refused
      try {
        held.push_back(std::make_unique<RawConnection>(d.socket()));
      } catch (const std::exception&) {
      }
    }
    [[maybe_unused]] auto w = write(ready[1], "r", 1);
    pause();  // until killed
    _exit(0);
  }
  close(ready[1]);
  char r = 0;
  ASSERT_EQ(read(ready[0], &r, 1), 1) << "the child could not run as nobody";
  close(ready[0]);
  // The daemon accepts them all; the 4 over the limit are refused busy
  // once their wait for a first request (1 s, issue 17) is over.
  json stats;
  const auto t0 = std::chrono::steady_clock::now();
  do {
    std::this_thread::sleep_for(200ms);
    stats = json::parse(d.ctl({"stats", "--json"}).out, nullptr, false);
  } while (stats["control"]["refused_busy"].get<int>() < 4 && std::chrono::steady_clock::now() - t0 < 10s);
  const auto estop = d.ctl({"estop"});
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
  EXPECT_EQ(estop.exit_code, 0) << estop.err;
  EXPECT_EQ(json::parse(d.ctl({"status", "--json"}).out, nullptr, false)["fault"], "estop");
  // `stats` itself was let in the same way (root is a writer).
  EXPECT_GE(stats["control"]["refused_busy"].get<int>(), 4) << stats["control"].dump();
}

/// Connects again and again and says nothing, keeping the newest `keep`
/// connections open: the daemon's accept loop and its places over the limit
/// under load.
class ConnectFlood {
 public:
  ConnectFlood(const std::filesystem::path& socket, std::size_t keep) {
    thread_ = std::thread([this, socket, keep] {
      std::deque<std::unique_ptr<RawConnection>> open;
      while (!stop_) {
        try {
          open.push_back(std::make_unique<RawConnection>(socket));
          ++made_;
        } catch (const std::exception&) {
          std::this_thread::sleep_for(1ms);
        }
        if (open.size() > keep) open.pop_front();
      }
    });
  }
  ~ConnectFlood() {
    stop_ = true;
    thread_.join();
  }
  ConnectFlood(const ConnectFlood&) = delete;
  ConnectFlood& operator=(const ConnectFlood&) = delete;
  int made() const { return made_; }
  /// Waits until it made `n` connections (or 20 s).
  bool reached(int n) const {
    const auto t0 = std::chrono::steady_clock::now();
    while (made_ < n && std::chrono::steady_clock::now() - t0 < 20s) std::this_thread::sleep_for(10ms);
    return made_ >= n;
  }

 private:
  std::atomic<bool> stop_{false};
  std::atomic<int> made_{0};
  std::thread thread_;
};

/// `count` connections to the socket, each served one status (so the daemon
/// holds them in its slots), then idle.
std::vector<std::unique_ptr<RawConnection>> hold_slots(const Daemon& d, int count) {
  std::vector<std::unique_ptr<RawConnection>> held;
  for (int i = 0; i < count; ++i) {
    held.push_back(std::make_unique<RawConnection>(d.socket()));
    held.back()->send(R"({"jsonrpc":"2.0","id":1,"method":"status"})"
                      "\n");
    if (held.back()->read_line().empty()) held.pop_back();
  }
  return held;
}

// Issue 17, defect 3: 16 idle connections of the same (privileged) user took
// every slot, and `hapticctl estop` got "busy: too many clients" (a writer
// evicts only readers). Now a connection over the limit has its first
// request read, and estop (and status) served: through the real hapticctl,
// with every slot held and a flood of connections that connect and say
// nothing, estop latches and status shows it.
TEST(Attack, EstopGetsThroughWhenPrivilegedIdleConnectionsHoldEverySlotUnderAConnectFlood) {
  TempDir dir;
  Daemon d(dir, device_config());
  ASSERT_TRUE(d.running()) << d.log();
  auto held = hold_slots(d, 16);  // max_clients
  ASSERT_EQ(held.size(), 16u);
  ConnectFlood flood(d.socket(), 200);
  ASSERT_TRUE(flood.reached(300)) << "the flood did not get going";
  const auto t0 = std::chrono::steady_clock::now();
  const auto estop = d.ctl({"estop"});
  const double estop_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  const auto status = d.ctl({"status", "--json"});
  const int flooded = flood.made();
  EXPECT_EQ(estop.exit_code, 0) << estop.out << estop.err;
  EXPECT_EQ(status.exit_code, 0) << status.err;
  EXPECT_EQ(json::parse(status.out, nullptr, false)["fault"], "estop") << status.out;
  // The slots' holders were not disturbed.
  ASSERT_TRUE(held.front()->send(R"({"jsonrpc":"2.0","id":2,"method":"status"})"
                                 "\n"));
  EXPECT_EQ(json::parse(held.front()->read_line(), nullptr, false)["result"]["fault"], "estop");
  std::printf(
      "hapticctl estop under a flood of %d connections, every slot held: %.1f ms (process included)\n",
      flooded, estop_ms);
  EXPECT_TRUE(d.running()) << d.log();
}

// The same for readers: 16 idle connections of a user outside the group and
// a flood of theirs; that user's own `hapticctl estop` (read access, by
// design) is served over the limit.
TEST(Attack, AReadersEstopGetsThroughWhenReadersHoldEverySlotUnderAConnectFlood) {
  if (geteuid() != 0) GTEST_SKIP() << "needs root to run as nobody";
  if (access("/usr/bin/setpriv", X_OK) != 0) GTEST_SKIP() << "no setpriv to run hapticctl as nobody";
  TempDir dir;
  Daemon d(dir, device_config());
  ASSERT_TRUE(d.running()) << d.log();
  chmod(dir.path.c_str(), 0755);    // nobody must reach the socket...
  chmod(d.socket().c_str(), 0666);  // ...and connect (read access only)
  int ready[2];
  ASSERT_EQ(pipe(ready), 0);
  const pid_t pid = fork();
  if (pid == 0) {
    close(ready[0]);
    if (setgroups(0, nullptr) != 0 || setgid(65534) != 0 || setuid(65534) != 0) _exit(121);
    auto held = hold_slots(d, 16);
    ConnectFlood flood(d.socket(), 200);
    if (held.size() != 16 || !flood.reached(300)) _exit(122);
    [[maybe_unused]] auto w = write(ready[1], "r", 1);
    pause();  // until killed
    _exit(0);
  }
  close(ready[1]);
  char r = 0;
  ASSERT_EQ(read(ready[0], &r, 1), 1) << "the child could not hold the slots as nobody";
  close(ready[0]);
  const std::vector<std::string> as_nobody{"--reuid=65534",  "--regid=65534",
                                           "--clear-groups", hapticctl_binary().string(),
                                           "--socket",       d.socket().string()};
  auto with = [&](std::vector<std::string> args, std::initializer_list<std::string> more) {
    args.insert(args.end(), more);
    return args;
  };
  const auto estop = run("/usr/bin/setpriv", with(as_nobody, {"estop"}));
  const auto status = run("/usr/bin/setpriv", with(as_nobody, {"status", "--json"}));
  kill(pid, SIGKILL);
  waitpid(pid, nullptr, 0);
  EXPECT_EQ(estop.exit_code, 0) << estop.out << estop.err;
  EXPECT_EQ(json::parse(status.out, nullptr, false)["fault"], "estop") << status.out << status.err;
  const json stats = json::parse(d.ctl({"stats", "--json"}).out, nullptr, false);
  EXPECT_GE(stats["control"]["over_limit_served"].get<int>(), 2) << stats["control"].dump();
}

// Issue 6, defect 3: `hapticctl stream --rate 1e-300` (any reader may) made a
// 1 ns timer: 431,484 notifications in 10 s and a full core. Rates outside
// 0.1..1000 Hz are refused, naming the range.
TEST(Attack, StreamRateOutsideItsRangeIsRefused) {
  TempDir dir;
  Daemon d(dir, device_config());
  ASSERT_TRUE(d.running()) << d.log();
  RawConnection c(d.socket());
  ASSERT_TRUE(c.send(R"({"jsonrpc":"2.0","id":1,"method":"stream","params":{"rate_hz":1e-300}})"
                     "\n"));
  const json reply = json::parse(c.read_line(), nullptr, false);
  EXPECT_EQ(reply["error"]["code"], -32602) << reply.dump();
  EXPECT_NE(reply["error"]["message"].get<std::string>().find("from 0.1 to 1000"), std::string::npos)
      << reply.dump();
  EXPECT_EQ(c.read_line(1s), "") << "samples after a refused stream";

  // hapticctl: a sample every 1e300 s could never arrive within --timeout.
  const auto tiny = d.ctl({"stream", "--rate", "1e-300", "--count", "1"});
  EXPECT_EQ(tiny.exit_code, 2) << tiny.out << tiny.err;
  EXPECT_NE(tiny.err.find("--timeout"), std::string::npos) << tiny.err;
  // Within --timeout but outside the daemon's range: the daemon's refusal.
  for (const char* rate : {"0.05", "2000"}) {
    const auto r = d.ctl({"stream", "--rate", rate, "--count", "1", "--timeout", "30"});
    EXPECT_EQ(r.exit_code, 1) << rate << ": " << r.out << r.err;
    EXPECT_NE(r.err.find("from 0.1 to 1000"), std::string::npos) << r.err;
  }
  const auto ok = d.ctl({"stream", "--rate", "1000", "--count", "5"});
  EXPECT_EQ(ok.exit_code, 0) << ok.err;
  EXPECT_TRUE(d.running()) << d.log();
}

/// A daemon that accepts `stream` and then never sends a sample.
class SilentDaemon {
 public:
  explicit SilentDaemon(const std::filesystem::path& socket) {
    listen_fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    const std::string text = socket.string();
    std::memcpy(addr.sun_path, text.c_str(), text.size() + 1);
    if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 ||
        ::listen(listen_fd_, 4) != 0)
      throw std::runtime_error("silent daemon: bind/listen failed");
    thread_ = std::thread([this] { serve(); });
  }
  ~SilentDaemon() {
    stop_ = true;
    thread_.join();
    ::close(listen_fd_);
  }
  SilentDaemon(const SilentDaemon&) = delete;
  SilentDaemon& operator=(const SilentDaemon&) = delete;

 private:
  void serve() {
    int fd = -1;
    std::string buffer;
    while (!stop_) {
      pollfd p{fd >= 0 ? fd : listen_fd_, POLLIN, 0};
      if (::poll(&p, 1, 50) <= 0) continue;
      if (fd < 0) {
        fd = ::accept(listen_fd_, nullptr, nullptr);
        continue;
      }
      char chunk[4096];
      const ssize_t n = ::recv(fd, chunk, sizeof chunk, 0);
      if (n <= 0) {
        ::close(fd);
        fd = -1;
        continue;
      }
      buffer.append(chunk, static_cast<std::size_t>(n));
      for (auto nl = buffer.find('\n'); nl != std::string::npos; nl = buffer.find('\n')) {
        const json request = json::parse(buffer.substr(0, nl), nullptr, false);
        buffer.erase(0, nl + 1);
        const json result = request.value("method", "") == "stream"
                                ? json{{"subscription", 1},
                                       {"rate_hz", request["params"]["rate_hz"]},
                                       {"channels", json::array()}}
                                : json{{"subscription", 1}, {"sent", 0}, {"dropped", 0}};
        const std::string line =
            json{{"jsonrpc", "2.0"}, {"id", request["id"]}, {"result", result}}.dump() + "\n";
        [[maybe_unused]] auto sent = ::send(fd, line.data(), line.size(), MSG_NOSIGNAL);
      }
    }
    if (fd >= 0) ::close(fd);
  }
  int listen_fd_ = -1;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// Issue 6, defect 3: hapticctl stream waited 1/rate + --timeout before it
// called the daemon silent (and 1/rate overflowed at tiny rates). --timeout
// is now the longest silence accepted: at 0.25 Hz with --timeout 5, exit 3
// after 5 s (it was 9 s).
TEST(Attack, StreamTimeoutIsTheSilenceAccepted) {
  TempDir dir;
  const auto socket = dir.path / "silent.sock";
  SilentDaemon silent(socket);
  const auto t0 = std::chrono::steady_clock::now();
  const auto r =
      run(hapticctl_binary(), {"--socket", socket.string(), "stream", "--rate", "0.25", "--timeout", "5"});
  const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_EQ(r.exit_code, 3) << r.out << r.err;
  EXPECT_NE(r.err.find("no telemetry from hapticd for 5 s"), std::string::npos) << r.err;
  EXPECT_GE(waited, 5.0);
  EXPECT_LT(waited, 7.5) << "hapticctl waited 1/rate + --timeout (9 s)";
}

}  // namespace
}  // namespace hapticd::e2e::attack_test
