// End-to-end: clients that misbehave at scale, against the real hapticd on
// the real clock. Each attack runs as long as an idle stretch measured just
// before it on the same daemon; the loop's overruns during the attack must
// stay at that idle baseline (compared generously: the host stalls this
// VM's vCPU for milliseconds about twice a second, and CTest runs two tests
// at a time), a well-behaved client polling `status` must be answered within
// 100 ms throughout, and afterwards the daemon's file descriptors are back
// to what they were and its memory near it. (The attacks of issue 6 --
// nesting, pipelining, readers holding every slot -- are in attack_test.cpp.)

#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "process_probe.hpp"
#include "support.hpp"

namespace hapticd::e2e::overload_test {
namespace {

using nlohmann::json;
using namespace std::chrono_literals;

constexpr const char* free_linear = R"(
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
)";

/// Runs `attack` (which returns when done) against a fresh daemon after an
/// idle stretch of the same length, with the prober running throughout.
struct Verdict {
  std::uint64_t idle_overruns = 0;
  std::uint64_t attack_overruns = 0;
  ProbeResult probe;
  ProcessUsage before, after;
  std::string log;
};

template <typename Attack>
Verdict under_attack(std::chrono::milliseconds length, Attack&& attack) {
  TempDir dir;
  Daemon d(dir, free_linear);
  EXPECT_TRUE(d.running()) << d.log();
  Verdict v;
  Prober prober(d.socket());  // connected first: it holds a slot throughout
  std::this_thread::sleep_for(300ms);
  v.before = usage_of(d.pid());
  reset_stats(d);
  std::this_thread::sleep_for(length);
  v.idle_overruns = overruns(d);
  reset_stats(d);
  const auto t0 = std::chrono::steady_clock::now();
  attack(d);
  const auto spent = std::chrono::steady_clock::now() - t0;
  if (spent < length) std::this_thread::sleep_for(length - spent);
  v.attack_overruns = overruns(d);
  v.probe = prober.finish();
  v.after = settled_usage(d, v.before.fds);
  v.log = d.log();
  EXPECT_TRUE(d.running()) << d.log();
  EXPECT_EQ(d.stop(), 0) << d.log();
  return v;
}

void expect_unharmed(const Verdict& v, const char* attack) {
  std::printf(
      "%s: overruns idle %llu, attacked %llu; status replies %zu, %.1f%% within 100 ms, max %.1f ms; "
      "fds %d -> %d, RSS %lld -> %lld KiB\n",
      attack, static_cast<unsigned long long>(v.idle_overruns),
      static_cast<unsigned long long>(v.attack_overruns), v.probe.replies, v.probe.within(100.0) * 100,
      v.probe.max_ms, v.before.fds, v.after.fds, static_cast<long long>(v.before.rss_kib),
      static_cast<long long>(v.after.rss_kib));
  EXPECT_LE(v.attack_overruns, generous_bound(v.idle_overruns)) << attack;
  EXPECT_GT(v.probe.replies, 10u) << attack;
  EXPECT_EQ(v.probe.failures, 0u) << attack
                                  << ": the well-behaved client lost its connection or got an error";
  // 100 ms for (almost) every reply; the rare host stall of tens of ms on
  // top of a busy moment is allowed once in a hundred, never a second.
  EXPECT_GE(v.probe.within(100.0), 0.99) << attack << ": max " << v.probe.max_ms << " ms";
  EXPECT_LT(v.probe.max_ms, 1000.0) << attack;
  EXPECT_EQ(v.after.fds, v.before.fds) << attack << ": file descriptors did not return\n" << v.log;
  EXPECT_LT(v.after.rss_kib, v.before.rss_kib + 32 * 1024) << attack << ": memory did not return";
}

// A client that sends requests and never reads a reply, and one that
// subscribes to 1 kHz telemetry and never reads it.
TEST(Overload, ClientsThatNeverReadDoNotDisturbTheLoopOrOthers) {
  const Verdict v = under_attack(3s, [](const Daemon& d) {
    RawConnection requester(d.socket());
    RawConnection subscriber(d.socket());
    subscriber.send(R"({"jsonrpc":"2.0","id":1,"method":"stream","params":{"rate_hz":1000}})"
                    "\n");
    std::string burst;
    for (int i = 0; i < 100; ++i)
      burst += R"({"jsonrpc":"2.0","id":1,"method":"scene.list"})"
               "\n";
    const auto end = std::chrono::steady_clock::now() + 3s;
    ::fcntl(requester.fd(), F_SETFL, O_NONBLOCK);
    while (std::chrono::steady_clock::now() < end) {
      // Non-blocking: once the daemon stops reading, the socket buffer fills.
      [[maybe_unused]] auto n = ::send(requester.fd(), burst.data(), burst.size(), MSG_NOSIGNAL);
      std::this_thread::sleep_for(5ms);
    }
  });
  expect_unharmed(v, "never reads");
}

// A request line of 1 GiB: refused at max_message_bytes (-32003), the
// connection closed; the daemon never holds more than the limit of it.
TEST(Overload, OneGibibyteLineIsRefusedWithoutBeingHeld) {
  std::uint64_t sent = 0;
  std::string reply;
  const Verdict v = under_attack(3s, [&](const Daemon& d) {
    RawConnection c(d.socket());
    const std::string chunk(1 << 20, 'x');
    c.send(R"({"jsonrpc":"2.0","id":1,"method":"status","pad":")");
    for (int i = 0; i < 1024 && c.send(chunk); ++i) sent += chunk.size();
    reply = c.read_line(5s);
  });
  std::printf("1 GiB line: %llu whole MiB sent before the daemon closed; reply %s\n",
              static_cast<unsigned long long>(sent >> 20), reply.c_str());
  EXPECT_NE(reply.find("-32003"), std::string::npos) << reply;
  EXPECT_LT(sent, std::uint64_t{1} << 30) << "the daemon read the whole gibibyte";
  expect_unharmed(v, "1 GiB line");
}

// 1,000 connections opened at once (max_clients is 16: the rest are told
// busy and closed), held, then all closed.
TEST(Overload, ThousandConnectionsAtOnce) {
  rlimit files{};
  getrlimit(RLIMIT_NOFILE, &files);
  if (files.rlim_cur < 1200) {
    files.rlim_cur = std::min<rlim_t>(files.rlim_max, 1200);
    setrlimit(RLIMIT_NOFILE, &files);
  }
  if (files.rlim_cur < 1100) GTEST_SKIP() << "needs 1100 file descriptors, has " << files.rlim_cur;
  std::size_t opened = 0;
  const Verdict v = under_attack(3s, [&](const Daemon& d) {
    std::vector<std::unique_ptr<RawConnection>> held;
    std::vector<std::thread> openers;
    std::mutex m;
    for (int t = 0; t < 4; ++t) {
      openers.emplace_back([&] {
        for (int i = 0; i < 250; ++i) {
          try {
            auto c = std::make_unique<RawConnection>(d.socket());
            std::lock_guard lock(m);
            held.push_back(std::move(c));
          } catch (const std::exception&) {
          }
        }
      });
    }
    for (auto& t : openers) t.join();
    opened = held.size();
    std::this_thread::sleep_for(1s);
  });
  std::printf("opened %zu of 1000 connections\n", opened);
  EXPECT_GE(opened, 900u);
  expect_unharmed(v, "1,000 connections");
}

// 100 clients connecting, asking and leaving, over and over, for 10 s.
TEST(Overload, HundredClientsComingAndGoingForTenSeconds) {
  std::atomic<std::uint64_t> sessions{0};
  const Verdict v = under_attack(10s, [&](const Daemon& d) {
    std::vector<std::thread> clients;
    const auto end = std::chrono::steady_clock::now() + 10s;
    for (int i = 0; i < 100; ++i) {
      clients.emplace_back([&, i] {
        while (std::chrono::steady_clock::now() < end) {
          try {
            RawConnection c(d.socket());
            if (i % 2 == 0) {
              c.send(R"({"jsonrpc":"2.0","id":1,"method":"status"})"
                     "\n");
              c.read_line(2s);
            }
            ++sessions;
          } catch (const std::exception&) {
          }
          std::this_thread::sleep_for(5ms);
        }
      });
    }
    for (auto& t : clients) t.join();
  });
  std::printf("%llu client sessions in 10 s\n", static_cast<unsigned long long>(sessions.load()));
  EXPECT_GT(sessions.load(), 1000u);
  expect_unharmed(v, "100 clients coming and going");
}

}  // namespace
}  // namespace hapticd::e2e::overload_test
