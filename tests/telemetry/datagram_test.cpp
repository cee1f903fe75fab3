// The datagram format against PlotJuggler's UDP JSON parser's rules
// (daemon/telemetry/datagram.hpp): the time field in every object, exact
// from integer nanoseconds; non-finite values as null and counted; channel
// layouts; the address and prefix rules.

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>

#include "daemon/telemetry/datagram.hpp"
#include "daemon/telemetry/udp_endpoint.hpp"

namespace hapticd::daemon::telemetry::datagram_test {
namespace {

using nlohmann::json;

TelemetrySample sample(std::uint64_t cycle) {
  TelemetrySample s;
  s.cycle = cycle;
  s.time_s = static_cast<double>(cycle) * 1e-3;
  s.position = 0.1 * static_cast<double>(cycle);
  s.command = -0.25;
  s.applied = -0.125;
  s.latency_s = 3e-6;
  s.compute_s = 1.5e-6;
  s.flags = 2;
  s.channel_count = 2;
  s.channels[0] = 1.0 / 3.0;
  s.channels[1] = 7.0;
  return s;
}

TEST(TelemetryTime, IsTheExactDecimalOfCycleTimesPeriod) {
  EXPECT_EQ(exact_seconds(0, 1'000'000), "0");
  EXPECT_EQ(exact_seconds(1, 1'000'000), "0.001");
  EXPECT_EQ(exact_seconds(3, 100'000),
            "0.0003");  // 3 x 100 us; 3 * 1e-4 in doubles is 0.00030000000000000003
  EXPECT_EQ(exact_seconds(1000, 1'000'000), "1");
  EXPECT_EQ(exact_seconds(123456789, 250'000), "30864.19725");
  EXPECT_EQ(exact_seconds(7, 333'333), "0.002333331");
  // Past 2^64 ns the product needs 128 bits; the text is still exact.
  EXPECT_EQ(exact_seconds(std::numeric_limits<std::uint64_t>::max(), 10'000'000), "184467440737095516.15");
  // Parsed, it is the double nearest the exact value: the same as the
  // correctly rounded quotient of the two integers.
  EXPECT_EQ(json::parse(exact_seconds(3, 100'000)).get<double>(), 300'000.0 / 1e9);
}

TEST(TelemetryObject, CarriesTAndTheChannelsNestedUnderThePrefix) {
  const auto layout =
      make_layout({"position", "applied", "velocity", "flags", "cycle"}, {"velocity", "spring"});
  std::string out;
  std::uint64_t non_finite = 0;
  append_object(out, sample(42), layout, "hapticd", 1'000'000, non_finite);
  EXPECT_EQ(
      out,
      R"({"t":0.042,"hapticd":{"position":4.2,"applied":-0.125,"velocity":0.3333333333333333,"flags":2,"cycle":42}})");
  const auto j = json::parse(out);
  EXPECT_TRUE(j.is_object());
  EXPECT_EQ(j["hapticd"]["position"].get<double>(), 0.1 * 42);  // shortest round trip: the same double
  EXPECT_EQ(non_finite, 0u);
}

TEST(TelemetryObject, NonFiniteValuesAreNullAndCounted) {
  auto s = sample(5);
  s.position = std::nan("");
  s.applied = std::numeric_limits<double>::infinity();
  s.command = -std::numeric_limits<double>::infinity();
  std::string out;
  std::uint64_t non_finite = 0;
  append_object(out, s, make_layout({"position", "command", "applied", "latency_s"}, {}), "p", 1'000'000,
                non_finite);
  EXPECT_EQ(out, R"({"t":0.005,"p":{"position":null,"command":null,"applied":null,"latency_s":3e-06}})");
  EXPECT_EQ(non_finite, 3u);
  EXPECT_TRUE(json::accept(out));  // nlohmann refuses NaN / Infinity tokens: none here
}

TEST(TelemetryChannels, DefaultIsTheRecordingsColumnsAndUnknownNamesAreFound) {
  const std::vector<std::string> scene{"velocity", "spring"};
  EXPECT_EQ(default_channels(scene),
            (std::vector<std::string>{"position", "velocity", "spring", "command", "applied", "latency_s",
                                      "compute_s", "flags"}));
  EXPECT_EQ(available_channels({}).back(), "time_s");
  EXPECT_EQ(unknown_channel({"position", "velocity"}, scene), std::nullopt);
  EXPECT_EQ(unknown_channel({"position", "speed"}, scene), "speed");
  EXPECT_EQ(make_layout({}, scene).size(), 8u);
  // A channel the (next) scene lacks is left out, not sent as a wrong value.
  const auto layout = make_layout({"position", "velocity"}, {"spring"});
  ASSERT_EQ(layout.size(), 1u);
  EXPECT_EQ(layout[0].name, "position");
}

TEST(TelemetryEndpoint, NumericAddressesOnlyAndLoopbackKnown) {
  const auto v4 = parse_endpoint("127.0.0.1:9870");
  ASSERT_TRUE(v4);
  EXPECT_TRUE(v4->loopback);
  EXPECT_EQ(v4->text, "127.0.0.1:9870");
  EXPECT_TRUE(parse_endpoint("127.8.9.10:1")->loopback);
  EXPECT_EQ(parse_endpoint("localhost:9870")->text, "127.0.0.1:9870");
  const auto v6 = parse_endpoint("[::1]:9870");
  ASSERT_TRUE(v6);
  EXPECT_TRUE(v6->loopback);
  EXPECT_EQ(v6->text, "[::1]:9870");
  EXPECT_TRUE(parse_endpoint("[::ffff:127.0.0.1]:5")->loopback);
  const auto lan = parse_endpoint("192.168.1.20:9870");
  ASSERT_TRUE(lan);
  EXPECT_FALSE(lan->loopback);
  EXPECT_FALSE(parse_endpoint("[2001:db8::1]:9870")->loopback);
  for (const char* bad :
       {"", "127.0.0.1", "127.0.0.1:", "127.0.0.1:0", "127.0.0.1:65536", "127.0.0.1:98x", "plotter.lab:9870",
        "::1:9870", "[::1]9870", "[::1]:", "1.2.3:9870", " 127.0.0.1:9870"}) {
    EXPECT_FALSE(parse_endpoint(bad)) << bad;
  }
}

TEST(TelemetryPrefix, IsAShortPathElement) {
  EXPECT_TRUE(valid_prefix("hapticd"));
  EXPECT_TRUE(valid_prefix("wheel-2_left"));
  EXPECT_FALSE(valid_prefix(""));
  EXPECT_FALSE(valid_prefix("a/b"));
  EXPECT_FALSE(valid_prefix("with space"));
  EXPECT_FALSE(valid_prefix("q\"uote"));
  EXPECT_FALSE(valid_prefix(std::string(33, 'a')));
}

}  // namespace
}  // namespace hapticd::daemon::telemetry::datagram_test
