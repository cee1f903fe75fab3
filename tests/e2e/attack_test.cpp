// End-to-end: the control-plane attacks of issue 6, replayed against the real
// hapticd: a request nested 60,000 levels deep, a client pipelining requests
// while others (and an estop) wait, readers holding every connection slot,
// and a stream rate that used to become a 1 ns timer.

#include <gtest/gtest.h>

#include <sys/resource.h>

#include <chrono>
#include <nlohmann/json.hpp>
#include <string>

#include "support.hpp"

namespace hapticd::e2e {
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

}  // namespace
}  // namespace hapticd::e2e
