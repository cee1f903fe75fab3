// End-to-end: UDP telemetry of the real hapticd ([telemetry], telemetry.set,
// `hapticctl telemetry`) received on a UDP port and checked against
// PlotJuggler's UDP JSON parser's rules (daemon/telemetry/datagram.hpp) and
// against the recording of the same run, sample for sample.

#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <fstream>
#include <map>
#include <mutex>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "support.hpp"

namespace hapticd::e2e::telemetry_test {
namespace {

using nlohmann::json;
using namespace std::chrono_literals;

/// A UDP port on 127.0.0.1 read continuously by a thread (or never, for the
/// receiver that never reads).
class UdpListener {
 public:
  explicit UdpListener(bool read = true) {
    fd_ = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) throw std::runtime_error("bind");
    int size = 16 << 20;  // root: past rmem_max, so a burst of the virtual clock fits
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVBUFFORCE, &size, sizeof size);
    socklen_t len = sizeof a;
    ::getsockname(fd_, reinterpret_cast<sockaddr*>(&a), &len);
    port_ = ntohs(a.sin_port);
    if (read) thread_ = std::thread([this] { loop(); });
  }
  ~UdpListener() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
    ::close(fd_);
  }
  std::string address() const { return "127.0.0.1:" + std::to_string(port_); }
  /// What arrived so far, once nothing more came for `quiet`.
  std::vector<std::string> settle(std::chrono::milliseconds quiet = 500ms) {
    std::size_t seen = static_cast<std::size_t>(-1);
    for (int i = 0; i < 100; ++i) {
      const std::size_t now = count();
      if (now == seen) break;
      seen = now;
      std::this_thread::sleep_for(quiet);
    }
    std::lock_guard lock(mutex_);
    return datagrams_;
  }
  std::size_t count() {
    std::lock_guard lock(mutex_);
    return datagrams_.size();
  }

 private:
  void loop() {
    std::vector<char> buffer(65536);
    while (!stop_) {
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 50) != 1) continue;
      const auto n = ::recv(fd_, buffer.data(), buffer.size(), 0);
      if (n < 0) continue;
      std::lock_guard lock(mutex_);
      datagrams_.emplace_back(buffer.data(), static_cast<std::size_t>(n));
    }
  }
  int fd_ = -1;
  std::uint16_t port_ = 0;
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::vector<std::string> datagrams_;
  std::thread thread_;
};

struct Received {
  std::uint64_t cycle;
  json channels;
};

/// Every datagram against PlotJuggler's parser's rules; returns the samples.
/// batch: objects per datagram (1: a bare object, else an array of up to batch).
std::vector<Received> check_plotjuggler_rules(const std::vector<std::string>& datagrams, std::uint32_t batch,
                                              const std::vector<std::string>& channels, double period_s) {
  std::vector<Received> out;
  double last_t = -1.0;
  for (const auto& d : datagrams) {
    SCOPED_TRACE(d);
    EXPECT_LE(d.size(), 2048u) << "one PlotJuggler UDP server reads 2048 bytes a datagram";
    // nlohmann's parser (PlotJuggler's) refuses NaN/Infinity: a parse error
    // would stop PlotJuggler's server.
    for (const char* token : {"NaN", "nan", "Infinity", "inf"}) EXPECT_EQ(d.find(token), std::string::npos);
    json j;
    EXPECT_NO_THROW(j = json::parse(d));
    if (j.is_discarded() || j.is_null()) continue;
    if (batch == 1) {
      EXPECT_TRUE(j.is_object());
      j = json::array({j});
    } else {
      EXPECT_TRUE(j.is_array());
      EXPECT_GE(j.size(), 1u);
      EXPECT_LE(j.size(), batch);
    }
    for (const auto& o : j) {
      EXPECT_TRUE(o.is_object());
      EXPECT_EQ(o.size(), 2u) << "only t and the prefix object";
      EXPECT_TRUE(o.contains("t") && o["t"].is_number()) << "the time field in every object";
      const double t = o.value("t", -1.0);
      EXPECT_GT(t, last_t) << "t strictly increasing";
      last_t = t;
      const auto cycle = static_cast<std::uint64_t>(std::llround(t / period_s));
      const auto period_ns = static_cast<std::uint64_t>(std::llround(period_s * 1e9));
      EXPECT_EQ(t, static_cast<double>(cycle * period_ns) / 1e9) << "t is cycle x period, exactly";
      const auto& values = o["hapticd"];
      EXPECT_TRUE(values.is_object());
      std::vector<std::string> keys;
      for (const auto& [k, v] : values.items()) {
        keys.push_back(k);
        EXPECT_TRUE(v.is_number() || v.is_null()) << k;
      }
      std::vector<std::string> want = channels;
      std::sort(want.begin(), want.end());
      std::sort(keys.begin(), keys.end());
      EXPECT_EQ(keys, want) << "the configured channels";
      out.push_back({cycle, values});
    }
  }
  return out;
}

/// The recording's row index by cycle.
std::map<std::uint64_t, std::size_t> rows_by_cycle(const Recording& rec) {
  std::map<std::uint64_t, std::size_t> out;
  const auto c = rec.column("cycle");
  for (std::size_t i = 0; i < rec.rows.size(); ++i) out[static_cast<std::uint64_t>(rec.rows[i][c])] = i;
  return out;
}

/// "hapticd: telemetry: S samples sent in D datagrams, X dropped (queue full Q, send failed F)"
std::map<std::string, std::uint64_t> telemetry_line(const std::string& log) {
  const std::regex line(
      R"(telemetry: (\d+) samples sent in (\d+) datagrams, (\d+) dropped \(queue full (\d+), send failed (\d+)\))");
  std::smatch m;
  if (!std::regex_search(log, m, line)) return {};
  return {{"sent", std::stoull(m[1])},
          {"datagrams", std::stoull(m[2])},
          {"dropped", std::stoull(m[3])},
          {"queue", std::stoull(m[4])},
          {"send", std::stoull(m[5])}};
}

std::string wheel(const std::string& clock, const std::string& telemetry) {
  return "[loop]\nperiod = \"1ms\"\nclock = \"" + clock +
         "\"\noverrun_limit = 0\n"
         "[device]\ndriver = \"loopback\"\n[device.loopback]\nmotion = \"rotary\"\n"
         "hand = \"mode=hold trajectory=sine amplitude=0.1 frequency=2\"\n"
         "[scene]\nname = \"spring-wheel\"\nintegrator = \"exact\"\n[telemetry]\n" +
         telemetry;
}

// The issue's evidence: every datagram by PlotJuggler's rules, the
// configured channels and rate, and each sample equal to the recording's
// row of its cycle. The virtual clock makes the run fast (3 s of world in
// well under one of wall time) and the comparison exact.
TEST(Telemetry, DatagramsFollowPlotJugglersRulesAndEqualTheRecording) {
  TempDir dir;
  UdpListener udp;
  const std::vector<std::string> channels{"position", "command", "applied"};
  Daemon d(dir,
           wheel("virtual",
                 "udp = \"" + udp.address() +
                     "\"\nrate_hz = 100\nchannels = [\"position\", \"command\", \"applied\"]\nbatch = 4\n"),
           {"--duration", "3s", "--record", "run.csv"});
  ASSERT_EQ(d.wait(), 0) << d.log();
  const auto datagrams = udp.settle();
  const auto samples = check_plotjuggler_rules(datagrams, 4, channels, 1e-3);
  const auto rec = read_recording(dir.path / "run.csv");
  ASSERT_GE(rec.rows.size(), 3000u);
  const auto counts = telemetry_line(d.log());
  ASSERT_FALSE(counts.empty()) << d.log();
  // 100 Hz of a 1 kHz loop: every 10th cycle; nothing may be lost on this
  // light load (the queue holds 8 s of it), so: all of them, in 4s.
  EXPECT_EQ(counts.at("dropped"), 0u) << d.log();
  EXPECT_EQ(samples.size(), rec.rows.size() / 10);
  EXPECT_EQ(counts.at("sent"), samples.size());
  // Full batches of 4, but a batch whose first sample waited 250 ms (a host
  // stall in the run) goes out partial: at least this many datagrams.
  EXPECT_GE(datagrams.size(), (samples.size() + 3) / 4);
  const auto rows = rows_by_cycle(rec);
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const auto& s = samples[i];
    EXPECT_EQ(s.cycle, 10 * (i + 1)) << "the rate: every 10th cycle";
    const auto row = rows.find(s.cycle);
    ASSERT_NE(row, rows.end()) << "cycle " << s.cycle << " not in the recording";
    const auto& r = rec.rows[row->second];
    EXPECT_EQ(s.channels["position"].get<double>(), r[rec.column("position_rad")]) << s.cycle;
    EXPECT_EQ(s.channels["command"].get<double>(), r[rec.column("command_n_m")]) << s.cycle;
    EXPECT_EQ(s.channels["applied"].get<double>(), r[rec.column("applied_n_m")]) << s.cycle;
  }
}

// The virtual clock at 1 kHz telemetry: 60,000 samples in a fraction of a
// second, more than a UDP sender may get through. The loop is never held
// up (the run completes, every cycle recorded) and every sample is either
// sent or counted as dropped; what arrives equals the recording.
TEST(Telemetry, AFastVirtualRunDeliversOrCountsEverySample) {
  TempDir dir;
  UdpListener udp;
  Daemon d(dir,
           wheel("virtual", "udp = \"" + udp.address() + "\"\nrate_hz = 1000\nchannels = [\"position\"]\n"),
           {"--duration", "60s", "--record", "run.csv"});
  ASSERT_EQ(d.wait(), 0) << d.log();
  const auto samples = check_plotjuggler_rules(udp.settle(), 1, {"position"}, 1e-3);
  const auto rec = read_recording(dir.path / "run.csv");
  ASSERT_EQ(rec.rows.size(), 60000u) << d.log();
  const auto counts = telemetry_line(d.log());
  ASSERT_FALSE(counts.empty()) << d.log();
  EXPECT_EQ(counts.at("sent") + counts.at("dropped"), 60000u) << d.log();
  EXPECT_EQ(counts.at("dropped"), counts.at("queue") + counts.at("send"));
  EXPECT_LE(samples.size(), counts.at("sent"));  // the receiver's own drops are its kernel's to count
  const auto rows = rows_by_cycle(rec);
  for (const auto& s : samples) {
    const auto row = rows.find(s.cycle);
    ASSERT_NE(row, rows.end());
    EXPECT_EQ(s.channels["position"].get<double>(), rec.rows[row->second][rec.column("position_rad")]);
  }
}

// telemetry.set: strict about its members (-32602 naming the member), only
// loopback or the configured address, and the stream follows what it set.
TEST(Telemetry, SetIsStrictLoopbackOnlyAndTakesEffect) {
  TempDir dir;
  UdpListener udp;
  Daemon d(dir, wheel("real", "udp = \"\"\n"));
  ASSERT_TRUE(d.running()) << d.log();
  const auto off = d.ctl({"--json", "telemetry"});
  ASSERT_EQ(off.exit_code, 0) << off.err;
  EXPECT_FALSE(json::parse(off.out)["enabled"].get<bool>());

  struct Bad {
    json params;
    const char* member;
  };
  const std::vector<Bad> bad{{{{"rate", 5}}, "rate"},
                             {{{"rate_hz", "fast"}}, "rate_hz"},
                             {{{"rate_hz", 5000}}, "rate_hz"},
                             {{{"rate_hz", 0}}, "rate_hz"},
                             {{{"batch", 0}}, "batch"},
                             {{{"batch", 2.5}}, "batch"},
                             {{{"batch", 65}}, "batch"},
                             {{{"channels", "position"}}, "channels"},
                             {{{"channels", {"position", 3}}}, "channels"},
                             {{{"channels", {"speed"}}}, "channels"},
                             {{{"prefix", "a/b"}}, "prefix"},
                             {{{"enabled", "yes"}}, "enabled"},
                             {{{"enabled", true}}, "enabled"},  // no address known
                             {{{"udp", 9870}}, "udp"},
                             {{{"udp", "plotter.lab:9870"}}, "udp"},
                             {{{"udp", "192.0.2.7:9870"}}, "udp"}};  // not loopback, not configured
  for (const auto& b : bad) {
    RawConnection c(d.socket());
    c.send(json{{"jsonrpc", "2.0"}, {"id", 1}, {"method", "telemetry.set"}, {"params", b.params}}.dump() +
           "\n");
    const auto reply = json::parse(c.read_line());
    SCOPED_TRACE(b.params.dump());
    ASSERT_TRUE(reply.contains("error")) << reply.dump();
    EXPECT_EQ(reply["error"]["code"], -32602);
    EXPECT_NE(reply["error"]["message"].get<std::string>().find(b.member), std::string::npos) << reply.dump();
  }

  const auto on = d.ctl({"--json", "telemetry", "on", "udp=" + udp.address(), "rate_hz=50",
                         "channels=position,applied", "batch=1"});
  ASSERT_EQ(on.exit_code, 0) << on.err;
  const auto set = json::parse(on.out);
  EXPECT_TRUE(set["enabled"].get<bool>());
  EXPECT_EQ(set["decimation"], 20);
  EXPECT_EQ(set["sending"], json({"position", "applied"}));
  for (int i = 0; i < 400 && udp.count() < 20; ++i) std::this_thread::sleep_for(10ms);
  const auto stopped = d.ctl({"telemetry", "off"});
  ASSERT_EQ(stopped.exit_code, 0) << stopped.err;
  const auto samples = check_plotjuggler_rules(udp.settle(300ms), 1, {"position", "applied"}, 1e-3);
  ASSERT_GE(samples.size(), 20u);
  for (std::size_t i = 1; i < samples.size(); ++i) EXPECT_EQ(samples[i].cycle % 20, 0u);
  // Off means off.
  const auto before = udp.count();
  std::this_thread::sleep_for(300ms);
  EXPECT_EQ(udp.count(), before);
  const auto human = d.ctl({"telemetry"});
  EXPECT_NE(human.out.find("telemetry: off"), std::string::npos) << human.out;
}

// Nobody listens on the configured port: the kernel refuses the datagrams,
// the daemon counts them in `stats` and the loop runs on, losing nothing
// it records.
TEST(Telemetry, AnUnreachablePortIsCountedInStatsAndStallsNothing) {
  TempDir dir;
  std::string closed;
  {
    UdpListener gone(false);
    closed = gone.address();
  }
  Daemon d(dir, wheel("real", "udp = \"" + closed + "\"\nrate_hz = 1000\n"), {"--record", "run.csv"});
  ASSERT_TRUE(d.running()) << d.log();
  json telemetry;
  for (int i = 0; i < 200; ++i) {
    const auto stats = d.ctl({"--json", "stats"});
    ASSERT_EQ(stats.exit_code, 0) << stats.err;
    telemetry = json::parse(stats.out)["telemetry"];
    if (telemetry["refused"].get<std::uint64_t>() > 10) break;
    std::this_thread::sleep_for(20ms);
  }
  EXPECT_GT(telemetry["refused"].get<std::uint64_t>(), 10u) << telemetry.dump();
  EXPECT_GT(telemetry["dropped_send"].get<std::uint64_t>(), 10u) << telemetry.dump();
  EXPECT_NE(telemetry["last_error"].get<std::string>().find("unreachable"), std::string::npos);
  std::this_thread::sleep_for(300ms);  // the loop runs on meanwhile
  ASSERT_EQ(d.stop(), 0) << d.log();
  const auto rec = read_recording(dir.path / "run.csv");
  EXPECT_GT(rec.rows.size(), 100u);
  EXPECT_NE(std::find(rec.comments.begin(), rec.comments.end(),
                      "# dropped 0 samples (ring full: 0, write failed: 0)"),
            rec.comments.end())
      << "the recording lost samples";
}

// A [telemetry] channel the configured scene does not have is a config
// error at its position, naming what is accepted.
TEST(Telemetry, AnUnknownConfiguredChannelIsAConfigErrorAtItsPosition) {
  TempDir dir;
  const auto config = dir.path / "bad.toml";
  std::ofstream(config) << "[scene]\nname = \"spring-wheel\"\n[telemetry]\nudp = \"127.0.0.1:9870\"\n"
                           "channels = [\"position\", \"speed\"]\n";
  const auto r = run(hapticd_binary(), {"--check-config", "--config", config.string()});
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.err.find("bad.toml:5:25: telemetry.channels names \"speed\""), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("accepted: position,"), std::string::npos) << r.err;
}

}  // namespace
}  // namespace hapticd::e2e::telemetry_test
