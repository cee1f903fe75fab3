// End-to-end: recordings when the disk fills. hapticd runs in its own mount
// namespace with its recording directory on a small tmpfs (a ballast file
// takes most of it); the test reads and frees that filesystem through
// /proc/<pid>/root. The counts hapticd reports must match the file.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "support.hpp"

namespace hapticd::e2e::recording_test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace std::chrono_literals;

json status_of(const Daemon& d) {
  const auto r = d.ctl({"status", "--json"});
  if (r.exit_code != 0) return json::object();
  return json::parse(r.out);
}

template <class Pred>
bool eventually(Pred pred, std::chrono::milliseconds timeout = 20s) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (!pred()) {
    if (std::chrono::steady_clock::now() > end) return false;
    std::this_thread::sleep_for(20ms);
  }
  return true;
}

/// unshare's arguments for a private mount namespace this process may make
/// (root: -m; otherwise a user namespace too), or empty if neither works.
std::vector<std::string> namespace_launcher() {
  for (const auto& flags : {std::vector<std::string>{"--mount"}, {"--map-root-user", "--mount"}}) {
    std::vector<std::string> args = flags;
    args.push_back("/bin/true");
    if (run("/usr/bin/unshare", args).exit_code == 0) {
      std::vector<std::string> launcher{"/usr/bin/unshare"};
      launcher.insert(launcher.end(), flags.begin(), flags.end());
      return launcher;
    }
  }
  return {};
}

struct Rows {
  std::uint64_t whole = 0;
  std::uint64_t torn = 0;
  std::vector<std::string> comments;
};

Rows scan(const std::string& text) {
  Rows rows;
  std::size_t fields = 0;
  std::size_t begin = 0;
  while (begin < text.size()) {
    const std::size_t end = text.find('\n', begin);
    const bool ended = end != std::string::npos;
    const std::string line = text.substr(begin, ended ? end - begin : std::string::npos);
    begin = ended ? end + 1 : text.size();
    if (line.starts_with("#")) {
      rows.comments.push_back(line);
    } else if (line.starts_with("time_s,")) {
      fields = static_cast<std::size_t>(std::count(line.begin(), line.end(), ',')) + 1;
    } else {
      const auto commas = static_cast<std::size_t>(std::count(line.begin(), line.end(), ','));
      ++(ended && commas + 1 == fields ? rows.whole : rows.torn);
    }
  }
  return rows;
}

// Issue 6: the disk filled under a recording; the file had whole rows plus a
// torn one and no trailer while hapticd reported fewer written and more
// dropped than the file showed. Now: the status says the disk is full, the
// loop runs on, writing resumes with a marked gap when space returns, and
// record.stop's counts are the file's.
TEST(RecordingDiskFull, StatusSaysSoLoopRunsOnAndTheCountsAreTheFiles) {
  const auto launcher_prefix = namespace_launcher();
  if (launcher_prefix.empty()) GTEST_SKIP() << "cannot make a mount namespace here (unshare refused)";
  TempDir dir;
  const fs::path mount_point = dir.path / "rec";
  fs::create_directory(mount_point);
  // Mount a 1 MiB tmpfs, fill all but 64 KiB with a ballast, become hapticd.
  const fs::path script = dir.path / "in-small-tmpfs.sh";
  std::ofstream(script) << "mount -t tmpfs -o size=1m tmpfs \"$1\" || exit 99\n"
                           "dd if=/dev/zero of=\"$1/ballast\" bs=1k count=960 status=none || exit 99\n"
                           "shift\nexec \"$@\"\n";
  std::vector<std::string> launcher = launcher_prefix;
  launcher.insert(launcher.end(), {"/bin/sh", script.string(), mount_point.string()});
  // The real clock at 1 ms: about 80 KB of rows per second, so the 64 KiB
  // fill in about a second and the freed 960 KiB take over ten.
  Daemon d(dir,
           "[loop]\nperiod = \"1ms\"\nclock = \"real\"\noverrun_limit = 0\n"
           "[device]\ndriver = \"loopback\"\ntorque_limit = 20.0\n"
           "[device.loopback]\nmotion = \"linear\"\nmass = 0.1\n"
           "[scene]\nname = \"free\"\n"
           "[recorder]\ndirectory = \"" +
               mount_point.string() + "\"\nflush_interval = \"20ms\"\n",
           {"--record", "full.csv"}, launcher);
  ASSERT_TRUE(d.running()) << d.log();
  // The file as hapticd sees it, through its mount namespace.
  const fs::path inside = fs::path("/proc") / std::to_string(d.pid()) / "root";
  const fs::path csv = inside / mount_point.relative_path() / "full.csv";

  ASSERT_TRUE(eventually([&] { return status_of(d)["recording"].value("disk_full", false); }))
      << status_of(d).dump();
  const json full = status_of(d);
  EXPECT_TRUE(full["recording"]["active"].get<bool>());
  EXPECT_NE(full["recording"]["error"].get<std::string>().find("No space left on device"), std::string::npos)
      << full.dump();
  // The loop keeps its period: it runs on, unfaulted, while the disk is full.
  EXPECT_EQ(full["state"], json("running"));
  const auto cycle = full["cycle"].get<std::uint64_t>();
  ASSERT_TRUE(eventually([&] { return status_of(d)["cycle"].get<std::uint64_t>() > cycle + 100; }));
  EXPECT_TRUE(status_of(d)["recording"]["disk_full"].get<bool>());

  // Space returns: writing resumes with a marked gap.
  fs::remove(inside / mount_point.relative_path() / "ballast");
  ASSERT_TRUE(eventually([&] {
    const json s = status_of(d);
    return !s["recording"].value("disk_full", true) && s["recording"].value("resumed", 0) >= 1;
  })) << status_of(d).dump();

  const auto r = d.ctl({"record", "stop", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json stopped = json::parse(r.out);
  std::ifstream in(csv, std::ios::binary);
  ASSERT_TRUE(in) << csv;
  std::ostringstream text;
  text << in.rdbuf();
  const Rows rows = scan(text.str());
  EXPECT_EQ(rows.torn, 0u) << "a partial row is left in the file";
  EXPECT_EQ(stopped["samples"].get<std::uint64_t>(), rows.whole) << stopped.dump();
  EXPECT_EQ(stopped["dropped_write"].get<std::uint64_t>(),
            stopped["samples_received"].get<std::uint64_t>() - stopped["samples"].get<std::uint64_t>());
  EXPECT_GT(stopped["dropped_write"].get<std::uint64_t>(), 0u);
  EXPECT_GE(stopped["resumed"].get<std::uint64_t>(), 1u);
  EXPECT_TRUE(stopped["complete"].get<bool>()) << stopped.dump();
  EXPECT_FALSE(stopped["disk_full"].get<bool>());
  bool gap = false;
  for (const auto& c : rows.comments) gap = gap || c.starts_with("# gap: ");
  EXPECT_TRUE(gap) << "no '# gap:' line";
  ASSERT_FALSE(rows.comments.empty());
  EXPECT_EQ(rows.comments.back(),
            "# dropped " +
                std::to_string(stopped["dropped_ring"].get<std::uint64_t>() +
                               stopped["dropped_write"].get<std::uint64_t>()) +
                " samples (ring full: " + std::to_string(stopped["dropped_ring"].get<std::uint64_t>()) +
                ", write failed: " + std::to_string(stopped["dropped_write"].get<std::uint64_t>()) + ")");
  EXPECT_EQ(d.stop(), 0) << d.log();
}

}  // namespace
}  // namespace hapticd::e2e::recording_test
