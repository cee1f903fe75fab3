// End-to-end fuzzing of the whole daemon over its socket: random and
// mutated JSON-RPC (the control_request fuzz corpus, every method the daemon
// has, random values), many connections, bounded in count and in time. The
// daemon must answer or close every connection, keep its loop at the
// overrun count of an idle stretch of the same length, and give back its
// file descriptors and memory. The seed is printed; HAPTICD_FUZZ_SEED
// replays a run, HAPTICD_FUZZ_LINES sets how many lines (default 3000).

#include <gtest/gtest.h>

#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "process_probe.hpp"
#include "support.hpp"

namespace hapticd::e2e::socket_fuzz_test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace std::chrono_literals;

const std::vector<std::string> methods{
    "status",    "stats",        "stats.reset", "scene.list",      "scene.load",     "param.get",
    "param.set", "record.start", "record.stop", "hand.set",        "fault.inject",   "fault.clear",
    "estop",     "stream",       "stream.stop", "device.describe", "no.such.method", ""};
const std::vector<std::string> keys{"scene",      "params",    "force",     "names",   "path",
                                    "mode",       "kind",      "amount",    "rate_hz", "channels",
                                    "stiffness",  "damping",   "delay",     "mass",    "integrator",
                                    "trajectory", "amplitude", "frequency", "text",    ""};

class Generator {
 public:
  explicit Generator(std::uint64_t seed) : rng_(seed) {
    const fs::path corpus = fs::path(HAPTICD_SOURCE_DIR) / "tests/fuzz/corpus/control_request";
    for (const auto& entry : fs::directory_iterator(corpus)) {
      std::ifstream in(entry.path(), std::ios::binary);
      std::stringstream text;
      text << in.rdbuf();
      std::stringstream lines(text.str());
      for (std::string line; std::getline(lines, line);) seeds_.push_back(line);
    }
    std::sort(seeds_.begin(), seeds_.end());  // directory order is not stable
  }

  /// One request line (without '\n'): a random request, or a seed mutated.
  std::string line() { return pick(3) == 0 ? mutate(seeds_[pick(seeds_.size())]) : random_request().dump(); }

 private:
  std::size_t pick(std::size_t n) { return std::uniform_int_distribution<std::size_t>(0, n - 1)(rng_); }

  json value(int depth) {
    switch (pick(depth > 3 ? 6 : 8)) {
      case 0:
        return nullptr;
      case 1:
        return pick(2) == 0;
      case 2:
        return std::uniform_int_distribution<std::int64_t>(-100, 100000)(rng_);
      case 3: {
        static const double specials[] = {0.0, -0.0, 1e308, -1e308, 4.9e-324, 1e-9, 9000.0, 46.0, 0.5};
        return specials[pick(9)];
      }
      case 4:
        return keys[pick(keys.size())];
      case 5:
        return std::string(pick(40), static_cast<char>('a' + pick(26)));
      case 6: {
        json a = json::array();
        for (std::size_t i = pick(4); i > 0; --i) a.push_back(value(depth + 1));
        return a;
      }
      default: {
        json o = json::object();
        for (std::size_t i = pick(4); i > 0; --i) o[keys[pick(keys.size())]] = value(depth + 1);
        return o;
      }
    }
  }

  json random_request() {
    json r{{"jsonrpc", "2.0"}, {"method", methods[pick(methods.size())]}};
    if (pick(8) != 0) r["id"] = pick(5) == 0 ? value(3) : json(pick(1000000));
    if (pick(6) != 0) {
      json params = json::object();
      for (std::size_t i = pick(4); i > 0; --i) params[keys[pick(keys.size())]] = value(1);
      r["params"] = pick(10) == 0 ? value(1) : params;
    }
    return r;
  }

  std::string mutate(std::string s) {
    for (std::size_t n = 1 + pick(4); n > 0; --n) {
      const std::size_t at = s.empty() ? 0 : pick(s.size());
      switch (pick(5)) {
        case 0:  // flip a byte (never to '\n': one line stays one line)
          if (!s.empty()) s[at] = static_cast<char>(pick(256) == '\n' ? ' ' : pick(256));
          break;
        case 1:  // insert structural characters
          s.insert(at, std::string(1 + pick(3), "{}[]\":,\\0e-"[pick(11)]));
          break;
        case 2:  // cut
          s.erase(at, pick(16));
          break;
        case 3:  // splice another seed in
          s.insert(at, seeds_[pick(seeds_.size())].substr(0, 1 + pick(30)));
          break;
        default:  // a number nobody expects
          s.insert(at, pick(2) == 0 ? "1e999" : "-9223372036854775809");
          break;
      }
    }
    std::replace(s.begin(), s.end(), '\n', ' ');
    return s;
  }

  std::mt19937_64 rng_;
  std::vector<std::string> seeds_;
};

/// Sends `lines` on a fresh connection, half-closes it, and reads until the
/// daemon closes it. True when it did within the timeout and everything it
/// sent was JSON lines.
struct Exchange {
  bool closed = false;
  std::size_t replies = 0;
  std::string bad;  ///< a line that was not JSON, if any
};
Exchange converse(const fs::path& socket, const std::vector<std::string>& lines) {
  Exchange x;
  RawConnection c(socket);
  std::string all;
  for (const auto& l : lines) all += l + "\n";
  c.send(all);  // false when the daemon closed first (e.g. a line too large): fine
  ::shutdown(c.fd(), SHUT_WR);
  const auto end = std::chrono::steady_clock::now() + 10s;
  std::string buffer;
  while (std::chrono::steady_clock::now() < end) {
    pollfd p{c.fd(), POLLIN, 0};
    if (::poll(&p, 1, 100) <= 0) continue;
    char chunk[65536];
    const ssize_t n = ::recv(c.fd(), chunk, sizeof chunk, 0);
    if (n <= 0) {
      x.closed = true;
      break;
    }
    buffer.append(chunk, static_cast<std::size_t>(n));
    for (auto nl = buffer.find('\n'); nl != std::string::npos; nl = buffer.find('\n')) {
      const std::string line = buffer.substr(0, nl);
      buffer.erase(0, nl + 1);
      if (json::parse(line, nullptr, false).is_discarded() && x.bad.empty()) x.bad = line;
      ++x.replies;
    }
  }
  return x;
}

std::uint64_t env_or(const char* name, std::uint64_t fallback) {
  const char* v = std::getenv(name);  // NOLINT(concurrency-mt-unsafe): tests set no environment
  return v != nullptr && *v != '\0' ? std::strtoull(v, nullptr, 10) : fallback;
}

TEST(SocketFuzz, DaemonAnswersOrClosesEveryConnectionAndComesBackToItsBaseline) {
  const std::uint64_t seed = env_or("HAPTICD_FUZZ_SEED", std::random_device{}());
  const std::uint64_t total_lines = env_or("HAPTICD_FUZZ_LINES", 3000);
  std::printf("socket fuzz: seed %llu (HAPTICD_FUZZ_SEED replays it), %llu lines\n",
              static_cast<unsigned long long>(seed), static_cast<unsigned long long>(total_lines));
  TempDir dir;
  Daemon d(dir, R"(
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
name = "wall"
stiffness = 9000
damping = 46
delay = 1
)");
  ASSERT_TRUE(d.running()) << d.log();
  // Warm up what is made on first use (the scene catalog, a stream timer).
  ASSERT_EQ(d.ctl({"scenes"}).exit_code, 0);
  ASSERT_EQ(d.ctl({"stream", "--rate", "100", "--count", "3"}).exit_code, 0);
  const auto length = 5s;
  const ProcessUsage before = settled_usage(d, usage_of(d.pid()).fds);
  reset_stats(d);
  std::this_thread::sleep_for(length);
  const std::uint64_t idle = overruns(d);
  reset_stats(d);

  Generator generate(seed);
  const auto t0 = std::chrono::steady_clock::now();
  std::uint64_t sent = 0, connections = 0, replies = 0;
  std::minstd_rand batch(static_cast<unsigned>(seed));
  while (sent < total_lines && std::chrono::steady_clock::now() - t0 < 20s) {
    std::vector<std::string> lines(1 + batch() % 40);
    for (auto& l : lines) l = generate.line();
    const Exchange x = converse(d.socket(), lines);
    ++connections;
    sent += lines.size();
    replies += x.replies;
    ASSERT_TRUE(x.closed) << "connection " << connections << " neither answered nor closed within 10 s; its "
                          << "lines:\n"
                          << [&] {
                               std::string s;
                               for (auto& l : lines) s += l + "\n";
                               return s;
                             }();
    ASSERT_EQ(x.bad, "") << "a reply that is not JSON";
    ASSERT_TRUE(d.running()) << "hapticd died; seed " << seed << "\n" << d.log();
  }
  const auto spent = std::chrono::steady_clock::now() - t0;
  if (spent < length) std::this_thread::sleep_for(length - spent);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const std::uint64_t attacked = overruns(d);
  // The daemon still does its job: status answers, the loop runs.
  const auto status = d.ctl({"status", "--json"});
  ASSERT_EQ(status.exit_code, 0) << status.err;
  d.ctl({"record", "stop"});  // a fuzzed record.start may have left one open (it holds a file)
  const ProcessUsage after = settled_usage(d, before.fds);
  std::printf(
      "socket fuzz: %llu lines on %llu connections in %.1f s, %llu reply lines; overruns idle %llu, "
      "fuzzed %llu (first %.1f s); fds %d -> %d; RSS %lld -> %lld KiB\n",
      static_cast<unsigned long long>(sent), static_cast<unsigned long long>(connections), seconds,
      static_cast<unsigned long long>(replies), static_cast<unsigned long long>(idle),
      static_cast<unsigned long long>(attacked), std::chrono::duration<double>(length).count(), before.fds,
      after.fds, static_cast<long long>(before.rss_kib), static_cast<long long>(after.rss_kib));
  // The fuzzed stretch may be longer than the idle one: scale the idle count.
  const double scale = std::max(1.0, seconds / std::chrono::duration<double>(length).count());
  EXPECT_LE(attacked, generous_bound(static_cast<std::uint64_t>(static_cast<double>(idle) * scale + 0.5)));
  EXPECT_EQ(after.fds, before.fds) << d.log();
  EXPECT_LT(after.rss_kib, before.rss_kib + 32 * 1024);
  EXPECT_EQ(d.stop(), 0) << d.log();
}

}  // namespace
}  // namespace hapticd::e2e::socket_fuzz_test
