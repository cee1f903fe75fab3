// End-to-end: what a recording holds when hapticd dies or is stopped.
// SIGKILL mid-recording: the file is readable up to its last flushed block
// (a header that parses, whole rows, consecutive cycles from 1). SIGTERM:
// nothing is lost, the rows are exactly the cycles the loop ran.
// (A full disk: recording_test.cpp; a failing sink: tests/recorder.)

#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "support.hpp"

namespace hapticd::e2e::process_faults_test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace std::chrono_literals;

// The wheel on the real clock with every scene channel recorded; overruns
// never latch a fault (the VM stalls).
constexpr const char* wheel_config = R"(
[loop]
period = "1ms"
clock = "real"
overrun_limit = 0
[device]
driver = "loopback"
[scene]
name = "spring-wheel"
[recorder]
flush_interval = "20ms"
)";

std::string config_in(const TempDir& dir) {
  return std::string(wheel_config) + "directory = \"" + dir.path.string() + "\"\n";
}

json status_of(const Daemon& d) {
  const auto r = d.ctl({"status", "--json"});
  return r.exit_code == 0 ? json::parse(r.out, nullptr, false) : json::object();
}

/// The file split at '\n': the lines it ends, and what follows the last one.
struct Lines {
  std::vector<std::string> ended;
  std::string tail;  ///< bytes after the last '\n' (a write cut short)
};
Lines split(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  const std::string s = text.str();
  Lines out;
  std::size_t begin = 0;
  for (std::size_t nl = s.find('\n'); nl != std::string::npos; nl = s.find('\n', begin)) {
    out.ended.push_back(s.substr(begin, nl - begin));
    begin = nl + 1;
  }
  out.tail = s.substr(begin);
  return out;
}

/// What a reader makes of a recording: the header block's keys, the column
/// line, and the data rows (each checked to have every column, as numbers).
struct Parsed {
  std::vector<std::string> header_keys;
  std::vector<std::string> columns;
  std::vector<std::uint64_t> cycles;
  std::string problem;  ///< empty when every ended line parsed
};
Parsed parse(const Lines& lines) {
  Parsed p;
  std::size_t cycle_column = 0;
  for (const auto& line : lines.ended) {
    if (line.starts_with("# ")) {
      if (p.columns.empty()) {
        const auto colon = line.find(": ");
        if (colon != std::string::npos) p.header_keys.push_back(line.substr(2, colon - 2));
      }
      continue;
    }
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string cell; std::getline(ss, cell, ',');) cells.push_back(cell);
    if (p.columns.empty()) {
      p.columns = cells;
      cycle_column = static_cast<std::size_t>(std::find(p.columns.begin(), p.columns.end(), "cycle") -
                                              p.columns.begin());
      if (cycle_column == p.columns.size()) p.problem = "no cycle column in '" + line + "'";
      continue;
    }
    if (cells == p.columns) continue;  // a new section's column line
    if (cells.size() != p.columns.size()) {
      p.problem = "row with " + std::to_string(cells.size()) + " of " + std::to_string(p.columns.size()) +
                  " fields: '" + line + "'";
      return p;
    }
    for (const auto& c : cells) {
      char* end = nullptr;
      std::strtod(c.c_str(), &end);
      if (c.empty() || *end != '\0') {
        p.problem = "not a number: '" + c + "' in '" + line + "'";
        return p;
      }
    }
    p.cycles.push_back(std::stoull(cells[cycle_column]));
  }
  return p;
}

bool has(const std::vector<std::string>& v, const std::string& x) {
  return std::find(v.begin(), v.end(), x) != v.end();
}

TEST(ProcessFaults, SigkillMidRecordingLeavesTheFileReadableUpToItsLastFlush) {
  TempDir dir;
  Daemon d(dir, config_in(dir), {"--record", "killed.csv"});
  ASSERT_TRUE(d.running()) << d.log();
  // Well into the recording, with several flushes behind it.
  std::uint64_t written = 0;
  const auto give_up = std::chrono::steady_clock::now() + 20s;
  while (written < 500 && std::chrono::steady_clock::now() < give_up) {
    written = status_of(d)["recording"].value("samples", std::uint64_t{0});
    std::this_thread::sleep_for(50ms);
  }
  ASSERT_GE(written, 500u) << status_of(d).dump();
  ASSERT_EQ(::kill(d.pid(), SIGKILL), 0);
  EXPECT_EQ(d.wait(10s), -SIGKILL);

  const Lines lines = split(dir.path / "killed.csv");
  const Parsed p = parse(lines);
  EXPECT_EQ(p.problem, "");
  ASSERT_FALSE(lines.ended.empty());
  EXPECT_EQ(lines.ended.front(), "# hapticd recording");
  for (const char* key : {"hapticd_version", "section", "start_utc", "scene", "period_s", "clock", "device"})
    EXPECT_TRUE(has(p.header_keys, key)) << "header without '" << key << "'";
  EXPECT_TRUE(has(p.columns, "time_s") && has(p.columns, "position_rad")) << lines.ended.size();
  // At least what status reported written before the kill, from cycle 1, none missing.
  ASSERT_GE(p.cycles.size(), written);
  EXPECT_EQ(p.cycles.front(), 1u);
  for (std::size_t i = 1; i < p.cycles.size(); ++i)
    ASSERT_EQ(p.cycles[i], p.cycles[i - 1] + 1) << "row " << i;
  // Whole lines are written at once: a kill leaves no torn row.
  EXPECT_EQ(lines.tail, "") << "a row cut short at the end of the file";
  // No trailer: the recorder never got to stop.
  EXPECT_FALSE(lines.ended.back().starts_with("# dropped")) << lines.ended.back();
}

TEST(ProcessFaults, SigtermLosesNothingTheRowsAreTheCyclesRun) {
  TempDir dir;
  Daemon d(dir, config_in(dir), {"--record", "term.csv"});
  ASSERT_TRUE(d.running()) << d.log();
  std::this_thread::sleep_for(700ms);
  ASSERT_EQ(d.stop(), 0) << d.log();
  std::smatch m;
  const std::string log = d.log();
  ASSERT_TRUE(std::regex_search(log, m, std::regex("loop stopped after ([0-9]+) cycles"))) << log;
  const std::uint64_t cycles_run = std::stoull(m[1].str());
  ASSERT_GT(cycles_run, 100u);

  const Lines lines = split(dir.path / "term.csv");
  const Parsed p = parse(lines);
  EXPECT_EQ(p.problem, "");
  EXPECT_EQ(lines.tail, "");
  ASSERT_EQ(p.cycles.size(), cycles_run) << "samples written != cycles run";
  EXPECT_EQ(p.cycles.front(), 1u);
  EXPECT_EQ(p.cycles.back(), cycles_run);
  for (std::size_t i = 1; i < p.cycles.size(); ++i)
    ASSERT_EQ(p.cycles[i], p.cycles[i - 1] + 1) << "row " << i;
  EXPECT_TRUE(has(lines.ended, "# samples_written: " + std::to_string(cycles_run)));
  EXPECT_EQ(lines.ended.back(), "# dropped 0 samples (ring full: 0, write failed: 0)");
}

}  // namespace
}  // namespace hapticd::e2e::process_faults_test
