// The sender thread on loopback: decimation, batches, the 2048-byte limit,
// a refused port and a full queue counted, never blocking the producer (the
// recorder thread in the daemon). No timed assertions: counts only.

#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "daemon/telemetry/datagram.hpp"
#include "daemon/telemetry/udp_telemetry.hpp"

namespace hapticd::daemon::telemetry::udp_telemetry_test {
namespace {

using nlohmann::json;
using namespace std::chrono_literals;

/// A UDP socket bound to 127.0.0.1 on a free port.
struct Receiver {
  int fd = -1;
  std::uint16_t port = 0;
  Receiver() {
    fd = ::socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    ::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
    int size = 8 << 20;
    ::setsockopt(fd, SOL_SOCKET, SO_RCVBUFFORCE, &size, sizeof size);
    socklen_t len = sizeof a;
    ::getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len);
    port = ntohs(a.sin_port);
  }
  ~Receiver() { ::close(fd); }
  std::string address() const { return "127.0.0.1:" + std::to_string(port); }
  /// Datagrams until `quiet` passes without one.
  std::vector<std::string> read_all(std::chrono::milliseconds quiet = 500ms) const {
    std::vector<std::string> out;
    char buffer[65536];
    pollfd p{fd, POLLIN, 0};
    while (::poll(&p, 1, static_cast<int>(quiet.count())) == 1) {
      const auto n = ::recv(fd, buffer, sizeof buffer, 0);
      if (n >= 0) out.emplace_back(buffer, static_cast<std::size_t>(n));
    }
    return out;
  }
};

std::vector<TelemetrySample> samples(std::uint64_t first, std::uint64_t count) {
  std::vector<TelemetrySample> out(count);
  for (std::uint64_t i = 0; i < count; ++i) {
    out[i].cycle = first + i;
    out[i].position = static_cast<double>(first + i) * 1e-3;
    out[i].channel_count = 1;
    out[i].channels[0] = -static_cast<double>(first + i);
  }
  return out;
}

/// Waits (bounded) until the sender has sent n samples: settings changed
/// after that apply to later samples only.
void wait_sent(const UdpTelemetry& t, std::uint64_t n) {
  for (int i = 0; i < 2000 && t.counters().samples_sent < n; ++i) std::this_thread::sleep_for(5ms);
}

Settings to(const Receiver& r, double rate_hz, std::uint32_t batch, std::vector<std::string> channels = {}) {
  Settings s;
  s.enabled = true;
  s.udp = parse_endpoint(r.address());
  s.rate_hz = rate_hz;
  s.batch = batch;
  s.channels = std::move(channels);
  return s;
}

TEST(UdpTelemetry, SendsEveryNthCycleInBatchesWithTInEveryObject) {
  Receiver r;
  UdpTelemetry t(1e-3);
  t.set_scene({"velocity"}, 0);
  t.apply(to(r, 100.0, 4, {"position", "velocity"}));  // 1 kHz loop, 100 Hz: every 10th cycle
  EXPECT_EQ(t.decimation(), 10u);
  const auto all = samples(1, 1000);
  for (std::size_t i = 0; i < all.size(); i += 50) t.offer(std::span(all).subspan(i, 50));
  t.stop();
  const auto datagrams = r.read_all();
  const auto c = t.counters();
  EXPECT_EQ(c.samples_queued, 100u);
  EXPECT_EQ(c.samples_sent, 100u);
  EXPECT_EQ(c.dropped_queue + c.samples_dropped_send, 0u);
  ASSERT_EQ(datagrams.size(), 25u);  // 100 samples, 4 per datagram
  std::uint64_t expected_cycle = 10;
  for (const auto& d : datagrams) {
    const auto batch = json::parse(d);
    ASSERT_TRUE(batch.is_array()) << d;
    EXPECT_EQ(batch.size(), 4u);
    for (const auto& o : batch) {
      ASSERT_TRUE(o.is_object());
      EXPECT_EQ(o["t"].get<double>(), static_cast<double>(expected_cycle * 1'000'000) / 1e9);
      EXPECT_EQ(o["hapticd"]["position"].get<double>(), static_cast<double>(expected_cycle) * 1e-3);
      EXPECT_EQ(o["hapticd"]["velocity"].get<double>(), -static_cast<double>(expected_cycle));
      EXPECT_EQ(o["hapticd"].size(), 2u);
      expected_cycle += 10;
    }
  }
}

TEST(UdpTelemetry, BatchOfOneIsABareObjectAndNoDatagramExceeds2048Bytes) {
  Receiver r;
  UdpTelemetry t(1e-3);
  t.set_scene({"velocity"}, 0);
  t.apply(to(r, 1000.0, 1));
  auto one = samples(1, 3);
  t.offer(one);
  wait_sent(t, 3);
  // 64 samples a datagram of every channel would be ~9 kB: split at 2048.
  t.apply(to(r, 1000.0, 64));
  auto many = samples(4, 640);
  t.offer(many);
  t.stop();
  const auto datagrams = r.read_all();
  ASSERT_GE(datagrams.size(), 3u);
  std::size_t objects = 0;
  double last_t = -1.0;
  for (std::size_t i = 0; i < datagrams.size(); ++i) {
    EXPECT_LE(datagrams[i].size(), max_datagram_bytes);
    const auto j = json::parse(datagrams[i]);
    if (i < 3) {
      EXPECT_TRUE(j.is_object()) << datagrams[i];
    } else {
      EXPECT_TRUE(j.is_array()) << datagrams[i];
    }
    for (const auto& o : j.is_array() ? j : json::array({j})) {
      EXPECT_GT(o["t"].get<double>(), last_t);
      last_t = o["t"].get<double>();
      ++objects;
    }
  }
  EXPECT_EQ(objects, 643u);
  EXPECT_EQ(t.counters().samples_sent, 643u);
}

TEST(UdpTelemetry, RefusedPortIsCountedAndNeverBlocks) {
  std::string closed;
  {
    Receiver gone;
    closed = gone.address();
  }  // nobody listens there now: ICMP port unreachable -> ECONNREFUSED
  UdpTelemetry t(1e-3);
  Settings s;
  s.enabled = true;
  s.udp = parse_endpoint(closed);
  s.rate_hz = 1000.0;
  t.apply(s);
  for (std::uint64_t round = 0; round < 20; ++round) {
    const auto batch = samples(1 + round * 10, 10);
    t.offer(batch);
    std::this_thread::sleep_for(5ms);  // let the ICMP errors come back between sends
  }
  t.stop();
  const auto c = t.counters();
  EXPECT_EQ(c.samples_queued, 200u);
  EXPECT_EQ(c.samples_sent + c.samples_dropped_send, 200u);  // every sample sent or counted
  EXPECT_GT(c.refused, 0u);
  EXPECT_EQ(c.datagrams_dropped, c.samples_dropped_send);
  EXPECT_NE(c.last_error.find("unreachable"), std::string::npos) << c.last_error;
}

TEST(UdpTelemetry, AFullQueueDropsAndCountsInsteadOfWaiting) {
  Receiver r;
  UdpTelemetry t(1e-4, 4);  // a queue of 4 samples
  t.apply(to(r, 10000.0, 1));
  const auto burst = samples(1, 5000);
  t.offer(burst);  // far more than the sender can take at once: returns anyway
  t.stop();
  const auto c = t.counters();
  EXPECT_EQ(c.samples_queued + c.dropped_queue, 5000u);  // every sample queued or counted
  EXPECT_GT(c.dropped_queue, 0u);
  EXPECT_EQ(c.samples_sent + c.samples_dropped_send, c.samples_queued);
}

TEST(UdpTelemetry, DisabledSendsNothingAndANewSceneRenamesFromItsCycle) {
  Receiver r;
  UdpTelemetry t(1e-3);
  t.set_scene({"velocity"}, 0);
  auto s = to(r, 1000.0, 1, {"position", "velocity", "spring"});
  s.enabled = false;
  t.apply(s);
  t.offer(samples(1, 10));
  EXPECT_EQ(t.counters().samples_queued, 0u);
  s.enabled = true;
  t.apply(s);
  t.set_scene({"spring"}, 13);  // from cycle 13 on, channel 0 is "spring"
  t.offer(samples(11, 4));
  t.stop();
  const auto datagrams = r.read_all();
  ASSERT_EQ(datagrams.size(), 4u);
  EXPECT_TRUE(json::parse(datagrams[1])["hapticd"].contains("velocity")) << datagrams[1];
  EXPECT_TRUE(json::parse(datagrams[2])["hapticd"].contains("spring")) << datagrams[2];
  EXPECT_FALSE(json::parse(datagrams[2])["hapticd"].contains("velocity")) << datagrams[2];
}

// A scene switch: the loop takes the new plan at a cycle the control thread
// learns only afterwards; samples the recorder hands over meanwhile wait in
// the queue, so each is named after the scene of its own cycle.
TEST(UdpTelemetry, HeldDuringASceneSwitchSoNamesFollowTheCycle) {
  Receiver r;
  UdpTelemetry t(1e-3);
  t.set_scene({"velocity"}, 0);
  t.apply(to(r, 1000.0, 1, {"velocity", "spring"}));
  t.hold_for_scene();
  t.offer(samples(1, 10));             // cycles 1 to 10; the new scene took effect at 6
  std::this_thread::sleep_for(100ms);  // unheld, the sender would have named them all by now
  t.set_scene({"spring"}, 6);
  t.stop();
  const auto datagrams = r.read_all();
  const auto c = t.counters();
  ASSERT_EQ(datagrams.size(), 10u) << "queued " << c.samples_queued << ", sent " << c.samples_sent
                                   << ", failed " << c.samples_dropped_send << ": " << c.last_error;
  for (std::size_t i = 0; i < datagrams.size(); ++i) {
    const auto values = json::parse(datagrams[i])["hapticd"];
    EXPECT_EQ(values.contains("velocity"), i < 5) << datagrams[i];
    EXPECT_EQ(values.contains("spring"), i >= 5) << datagrams[i];
  }
}

}  // namespace
}  // namespace hapticd::daemon::telemetry::udp_telemetry_test
