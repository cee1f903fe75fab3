// The persisted origin (docs/config.md, "Calibration"): its file reads back
// exactly what was written, bad input is refused naming the file, line,
// column, key and what is accepted, a file for another device is refused
// naming the field, and it is written atomically. The [device] keys that
// choose it are parsed with their defaults and errors.
#include "daemon/config/origin_file.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "daemon/config/config.hpp"
#include "daemon/config/host_checks.hpp"

namespace hapticd::daemon::config::origin_file_test {
namespace {

namespace fs = std::filesystem;

struct TempDir {
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "hapticd-origin-XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    path = pattern;
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  fs::path path;
};

OriginRecord wheel_zeroed() {
  OriginRecord r;
  r.position = 0.78539816339744828;
  r.set_by = "zero";
  r.cycle = 12345;
  r.set_at = "2026-12-05T10:00:00Z";
  r.identity = {"canopen", "interface can0, node 1, vendor 0x00000000, serial 0x00000001", "incremental",
                "rotary", 0.00038349519697141029};
  return r;
}

/// The error parse_origin() gives for `text`, "" if it parsed.
std::string refusal(const std::string& text) {
  try {
    parse_origin(text, "origin.toml");
  } catch (const OriginFileError& e) {
    return e.what();
  }
  return "";
}

std::string with(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  if (at == std::string::npos) throw std::logic_error("no '" + from + "' in the text");
  return text.replace(at, from.size(), to);
}

TEST(OriginFile, ReadsBackExactlyWhatWasWritten) {
  const OriginRecord zeroed = wheel_zeroed();
  EXPECT_EQ(parse_origin(format_origin(zeroed), "o"), zeroed);
  OriginRecord homed = zeroed;
  homed.set_by = "homing";
  homed.homing_method = 37;
  homed.position = 0.0;
  homed.cycle = 0;
  homed.identity.motion = "linear";
  homed.identity.resolution = 1e-6;
  const std::string text = format_origin(homed);
  EXPECT_NE(text.find("unit = \"m\""), std::string::npos) << text;
  EXPECT_NE(text.find("homing_method = 37"), std::string::npos) << text;
  EXPECT_EQ(parse_origin(text, "o"), homed);
}

TEST(OriginFile, BadInputIsRefusedNamingWhereAndWhatIsAccepted) {
  const std::string good = format_origin(wheel_zeroed());
  ASSERT_EQ(refusal(good), "");
  // Where the position line is: line 4 (two comment lines, [origin]).
  EXPECT_EQ(
      refusal(with(good, "position = 0.7853981633974483", "position = \"0.78\"")),
      "origin.toml:4:12: origin.position = \"0.78\" is not accepted; accepted: a finite number (m or rad, "
      "in the device's frame)");
  EXPECT_NE(
      refusal(with(good, "position = 0.7853981633974483", "position = nan")).find("origin.position = nan"),
      std::string::npos);
  EXPECT_NE(refusal(with(good, "position = 0.7853981633974483\n", "")).find("[origin] has no position"),
            std::string::npos);
  EXPECT_NE(refusal(with(good, "set_by = \"zero\"", "set_by = \"guess\""))
                .find("origin.set_by = \"guess\" is not accepted; accepted: \"zero\" or \"homing\""),
            std::string::npos);
  EXPECT_NE(
      refusal(with(good, "set_by = \"zero\"", "set_by = \"homing\"")).find("[origin] has no homing_method"),
      std::string::npos);
  EXPECT_NE(
      refusal(with(good, "encoder = \"incremental\"", "encoder = \"optical\""))
          .find("identity.encoder = \"optical\" is not accepted; accepted: \"incremental\" or \"absolute\""),
      std::string::npos);
  EXPECT_NE(refusal(with(good, "unit = \"rad\"", "unit = \"m\""))
                .find("origin.unit = \"m\" does not match identity.motion = \"rotary\""),
            std::string::npos);
  EXPECT_NE(refusal(with(good, "resolution = ", "resolution = -")).find("identity.resolution = -0.000383"),
            std::string::npos);
  EXPECT_NE(refusal(good + "extra = 1\n").find("unknown key 'extra' in [identity]; accepted: driver, device"),
            std::string::npos);
  EXPECT_NE(refusal(good + "[more]\n").find("unknown section [more] in an origin file"), std::string::npos);
  EXPECT_NE(refusal(with(good, "[identity]", "[ident]")).find("unknown section [ident]"), std::string::npos);
  EXPECT_NE(refusal("position = 1\n").find("unknown key 'position' in an origin file"), std::string::npos);
  EXPECT_NE(refusal("").find("lacks [origin]"), std::string::npos);
  // A torn write (the file cut in the middle of a line) is a syntax error, said so.
  const std::string torn = refusal(good.substr(0, good.find("set_at") + 10));
  EXPECT_NE(torn.find("origin.toml:"), std::string::npos) << torn;
  EXPECT_NE(torn.find("not an origin file (TOML syntax error"), std::string::npos) << torn;
  // Bytes that are no text at all.
  EXPECT_NE(refusal(std::string("\x00\xff\xfe[origin]", 11)).find("not an origin file"), std::string::npos);
}

TEST(OriginFile, AFileForAnotherDeviceOrEncoderIsRefusedNamingTheField) {
  const OriginIdentity stored = wheel_zeroed().identity;
  EXPECT_EQ(identity_mismatch(stored, stored), "");
  OriginIdentity other = stored;
  other.device = "interface can0, node 1, vendor 0x00000000, serial 0x00000002";
  EXPECT_EQ(
      identity_mismatch(stored, other),
      "it was written for device \"interface can0, node 1, vendor 0x00000000, serial 0x00000001\", this "
      "device has \"interface can0, node 1, vendor 0x00000000, serial 0x00000002\"");
  other = stored;
  other.encoder = "absolute";
  EXPECT_EQ(identity_mismatch(stored, other),
            "it was written for encoder \"incremental\", this device has \"absolute\"");
  other = stored;
  other.resolution = stored.resolution * 2;
  EXPECT_NE(identity_mismatch(stored, other).find("resolution"), std::string::npos);
  other = stored;
  other.driver = "modbus";
  EXPECT_NE(identity_mismatch(stored, other).find("driver \"canopen\""), std::string::npos);
}

TEST(OriginFile, IsWrittenAtomicallyAndReadBack) {
  TempDir dir;
  const fs::path file = dir.path / "origin.toml";
  EXPECT_FALSE(load_origin_file(file).has_value()) << "no file: nothing to restore";
  write_origin_file(file, wheel_zeroed());
  OriginRecord second = wheel_zeroed();
  second.position = -3.5;
  write_origin_file(file, second);
  const auto read = load_origin_file(file);
  ASSERT_TRUE(read.has_value());
  EXPECT_EQ(*read, second);
  std::size_t entries = 0;
  for (const auto& e : fs::directory_iterator(dir.path))
    entries += e.path().filename() == "origin.toml" ? 1 : 100;
  EXPECT_EQ(entries, 1u) << "no temporary file left behind";
  // A file that is not an origin: refused with its path.
  std::ofstream(file) << with(format_origin(second), "position = -3.5", "position = \"x\"");
  try {
    load_origin_file(file);
    ADD_FAILURE() << "accepted a bad file";
  } catch (const OriginFileError& e) {
    EXPECT_NE(std::string(e.what()).find(file.string() + ":4:12: origin.position"), std::string::npos)
        << e.what();
  }
  // A directory that takes no files: the error names the path.
  if (::geteuid() != 0) {
    ::chmod(dir.path.c_str(), 0500);
    try {
      write_origin_file(file, second);
      ADD_FAILURE() << "wrote into a read-only directory";
    } catch (const std::system_error& e) {
      EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    }
    ::chmod(dir.path.c_str(), 0700);
  }
}

TEST(OriginConfig, KeysDefaultsAndErrors) {
  const DaemonConfig defaults = parse_config("", "t.toml");
  EXPECT_EQ(defaults.device.encoder, EncoderKind::incremental);
  EXPECT_FALSE(defaults.device.origin.has_value());
  EXPECT_EQ(defaults.device.origin_keeping(), OriginKeeping::session) << "incremental: for this session";
  EXPECT_FALSE(defaults.device.require_calibration);
  EXPECT_EQ(resolve_origin_file(defaults.device, nullptr), fs::path("origin.toml"));
  EXPECT_EQ(resolve_origin_file(defaults.device, "/var/lib/hapticd/wheel:/other"),
            fs::path("/var/lib/hapticd/wheel/origin.toml"));

  const DaemonConfig absolute = parse_config("[device]\nencoder = \"absolute\"\n", "t.toml");
  EXPECT_EQ(absolute.device.origin_keeping(), OriginKeeping::persist) << "absolute: kept";
  const DaemonConfig chosen = parse_config(
      "[device]\nencoder = \"absolute\"\norigin = \"session\"\norigin_file = \"state/o.toml\"\n"
      "require_calibration = true\n",
      "/etc/hapticd/t.toml");
  EXPECT_EQ(chosen.device.origin_keeping(), OriginKeeping::session);
  EXPECT_TRUE(chosen.device.require_calibration);
  EXPECT_EQ(chosen.device.origin_file, "/etc/hapticd/state/o.toml") << "relative to the config file";
  EXPECT_EQ(chosen.device.origin_where.to_string(), "/etc/hapticd/t.toml:3:10");

  auto error = [](const std::string& text) {
    try {
      parse_config(text, "t.toml");
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(
      error("[device]\norigin = \"forever\"\n"),
      "t.toml:2:10: device.origin = \"forever\" is not accepted; accepted: \"session\" (a calibration "
      "lasts until hapticd stops) or \"persist\" (kept in the state directory and restored at start-up)");
  EXPECT_EQ(error("[device]\nencoder = 3\n"),
            "t.toml:2:11: device.encoder = 3 has the wrong type; accepted: \"incremental\" or \"absolute\"");
  EXPECT_EQ(error("[device]\nrequire_calibration = \"yes\"\n"),
            "t.toml:2:23: device.require_calibration = \"yes\" has the wrong type; accepted: true or false");
}

TEST(OriginConfig, ThePersistedFilesDirectoryIsCheckedOnTheHost) {
  TempDir dir;
  const std::string base = "[control]\nsocket = \"" + (dir.path / "s.sock").string() +
                           "\"\n[recorder]\ndirectory = \"" + dir.path.string() + "\"\n";
  // Persisting into a directory below a regular file cannot work: refused at the key.
  std::ofstream(dir.path / "plain") << "x";
  const DaemonConfig bad = parse_config(base + "[device]\norigin = \"persist\"\norigin_file = \"" +
                                            (dir.path / "plain" / "o.toml").string() + "\"\n",
                                        "t.toml");
  try {
    check_host(bad, nullptr);
    ADD_FAILURE() << "accepted";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.key(), "device.origin_file");
    EXPECT_NE(std::string(e.what()).find("t.toml:7:15: device.origin_file = "), std::string::npos)
        << e.what();
  }
  // Session: the file is never written, so not checked.
  const DaemonConfig session = parse_config(
      base + "[device]\norigin_file = \"" + (dir.path / "plain" / "o.toml").string() + "\"\n", "t.toml");
  EXPECT_NO_THROW(check_host(session, nullptr));
  // Under systemd, the state directory's origin.toml.
  const DaemonConfig persist = parse_config(base + "[device]\norigin = \"persist\"\n", "t.toml");
  const std::string state = (dir.path / "state").string();
  EXPECT_NO_THROW(check_host(persist, state.c_str()));
  EXPECT_TRUE(fs::is_directory(dir.path / "state")) << "created, as the recordings' directory";
}

}  // namespace
}  // namespace hapticd::daemon::config::origin_file_test
