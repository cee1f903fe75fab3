// [telemetry]: every key, and each error at its position naming what is
// accepted (docs/config.md).

#include <gtest/gtest.h>

#include <string>

#include "daemon/config/config.hpp"

namespace hapticd::daemon::config::telemetry_config_test {
namespace {

std::string telemetry_error(const std::string& toml) {
  try {
    (void)parse_config(toml, "t.toml");
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "accepted";
}

TEST(TelemetryConfig, AllKeysParse) {
  const auto c = parse_config(
      "[loop]\nperiod = \"500us\"\n[telemetry]\nudp = \"[::1]:9870\"\nrate_hz = 2000\n"
      "channels = [\"position\", \"applied\"]\nbatch = 8\nprefix = \"wheel-1\"\n",
      "t.toml");
  EXPECT_EQ(c.telemetry.udp, "[::1]:9870");
  EXPECT_EQ(c.telemetry.rate_hz, 2000.0);
  EXPECT_EQ(c.telemetry.channels, (std::vector<std::string>{"position", "applied"}));
  ASSERT_EQ(c.telemetry.channel_where.size(), 2u);
  EXPECT_EQ(c.telemetry.channel_where[1].to_string(), "t.toml:6:25");
  EXPECT_EQ(c.telemetry.batch, 8u);
  EXPECT_EQ(c.telemetry.prefix, "wheel-1");
}

TEST(TelemetryConfig, DefaultIsOff) {
  const auto c = default_config();
  EXPECT_TRUE(c.telemetry.udp.empty());
  EXPECT_EQ(c.telemetry.rate_hz, 100.0);
  EXPECT_TRUE(c.telemetry.channels.empty());
  EXPECT_EQ(c.telemetry.batch, 1u);
  EXPECT_EQ(c.telemetry.prefix, "hapticd");
}

TEST(TelemetryConfig, ErrorsAreAtTheValueAndSayWhatIsAccepted) {
  EXPECT_EQ(telemetry_error("[telemetry]\nudp = \"plotter:9870\"\n")
                .rfind("t.toml:2:7: telemetry.udp = "
                       "\"plotter:9870\" is not an address; "
                       "accepted: \"\" (off) or \"ADDRESS:PORT\"",
                       0),
            0u);
  EXPECT_EQ(telemetry_error("[telemetry]\nudp = 9870\n")
                .rfind("t.toml:2:7: telemetry.udp = 9870 has the wrong type", 0),
            0u);
  // The loop rate bounds rate_hz, whichever section comes first.
  EXPECT_EQ(telemetry_error("[telemetry]\nrate_hz = 2000\n[loop]\nperiod = \"1ms\"\n"),
            "t.toml:2:11: telemetry.rate_hz = 2000 is out of range; accepted: 0.1 to 1000.0 (the loop rate, "
            "1 / loop.period)");
  EXPECT_EQ(telemetry_error("[telemetry]\nrate_hz = 0.01\n")
                .rfind("t.toml:2:11: telemetry.rate_hz = 0.01 is out of range", 0),
            0u);
  EXPECT_EQ(
      telemetry_error("[telemetry]\nbatch = 65\n")
          .rfind("t.toml:2:9: telemetry.batch = 65 is out of range; accepted: an integer from 1 to 64", 0),
      0u);
  EXPECT_EQ(telemetry_error("[telemetry]\nprefix = \"a/b\"\n")
                .rfind("t.toml:2:10: telemetry.prefix = \"a/b\" is out of range", 0),
            0u);
  EXPECT_EQ(
      telemetry_error("[telemetry]\nchannels = \"position\"\n")
          .rfind("t.toml:2:12: telemetry.channels = \"position\" has the wrong type; accepted: an array", 0),
      0u);
  EXPECT_EQ(telemetry_error("[telemetry]\nchannels = [\"position\", 3]\n")
                .rfind("t.toml:2:25: telemetry.channels = 3 has the wrong type", 0),
            0u);
  EXPECT_EQ(telemetry_error("[telemetry]\nchannels = [\"applied\", \"applied\"]\n"),
            "t.toml:2:24: telemetry.channels names \"applied\" twice");
  EXPECT_EQ(telemetry_error("[telemetry]\nport = 9870\n"),
            "t.toml:2:1: unknown key 'port' in [telemetry]; accepted: udp, rate_hz, channels, batch, prefix");
}

}  // namespace
}  // namespace hapticd::daemon::config::telemetry_config_test
