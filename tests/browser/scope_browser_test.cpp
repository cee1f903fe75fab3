// `hapticctl scope` in Debian's headless Chromium during a run of the real
// hapticd (ctest label `browser`: once per CI, not in the sanitizer builds).
// The page is driven through the DevTools protocol over a pipe
// (--remote-debugging-pipe: NUL-separated JSON on fds 3 and 4). It checks:
// - the samples the page holds (its hook window.hapticdScope) equal the
//   recording of the same run, row for row, channel for channel;
// - the page loads with no network: every request it makes goes to the
//   hapticctl that served it (Chromium runs with a dead proxy for every other
//   host and no name resolution), and its HTML names no other URL;
// - the scene, its stability verdict and the fault state are on it.
// The screenshot goes to $HAPTICD_SCOPE_SCREENSHOT when set (docs/figures/).

#include <gtest/gtest.h>

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "support.hpp"

namespace hapticd::e2e::scope_browser_test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

pid_t start(const std::vector<std::string>& argv, const fs::path& log, int pipe_in = -1, int pipe_out = -1) {
  const pid_t pid = ::fork();
  if (pid != 0) return pid;
  const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  ::dup2(fd, STDOUT_FILENO);
  ::dup2(fd, STDERR_FILENO);
  if (pipe_in >= 0) {
    // --remote-debugging-pipe: Chromium reads commands on 3, writes on 4.
    // Up out of the way first (either may be 3 or 4 now); dup2 clears O_CLOEXEC.
    const int in = ::fcntl(pipe_in, F_DUPFD, 10);
    const int out = ::fcntl(pipe_out, F_DUPFD, 10);
    ::dup2(in, 3);
    ::dup2(out, 4);
  }
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  ::execv(args[0], args.data());
  ::_exit(127);
}

void end(pid_t pid, int sig) {
  if (pid <= 0) return;
  ::kill(pid, sig);
  for (int i = 0; i < 200; ++i) {
    int status = 0;
    if (::waitpid(pid, &status, WNOHANG) == pid) return;
    std::this_thread::sleep_for(25ms);
  }
  ::kill(pid, SIGKILL);
  ::waitpid(pid, nullptr, 0);
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string base64_decode(const std::string& in) {
  std::string out;
  int bits = 0;
  std::uint32_t acc = 0;
  for (const char c : in) {
    int v = -1;
    if (c >= 'A' && c <= 'Z') v = c - 'A';
    if (c >= 'a' && c <= 'z') v = c - 'a' + 26;
    if (c >= '0' && c <= '9') v = c - '0' + 52;
    if (c == '+') v = 62;
    if (c == '/') v = 63;
    if (v < 0) continue;
    acc = (acc << 6) | static_cast<std::uint32_t>(v);
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out += static_cast<char>((acc >> bits) & 0xff);
    }
  }
  return out;
}

/// Headless Chromium with the DevTools protocol on a pipe.
class Chromium {
 public:
  explicit Chromium(const fs::path& dir) {
    int to[2], from[2];
    if (::pipe2(to, O_CLOEXEC) != 0 || ::pipe2(from, O_CLOEXEC) != 0) throw std::runtime_error("pipe");
    pid_ = start(
        {"/usr/bin/chromium", "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
         "--no-first-run", "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-dev-shm-usage", "--hide-scrollbars", "--mute-audio",
         "--user-data-dir=" + (dir / "profile").string(), "--window-size=1280,860",
         // No network: every host but loopback (bypassed implicitly)
         // goes to a proxy nobody runs, and no name resolves.
         "--proxy-server=http://127.0.0.1:9", "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1",
         "--remote-debugging-pipe", "about:blank"},
        dir / "chromium.log", to[0], from[1]);
    ::close(to[0]);
    ::close(from[1]);
    write_fd_ = to[1];
    read_fd_ = from[0];
  }
  ~Chromium() {
    ::close(write_fd_);  // Chromium exits when its pipe closes
    end(pid_, SIGTERM);
    ::close(read_fd_);
  }
  Chromium(const Chromium&) = delete;
  Chromium& operator=(const Chromium&) = delete;

  /// A command and its result; events that arrive meanwhile are kept.
  json call(const std::string& method, const json& params = json::object(), const std::string& session = "") {
    const int id = next_id_++;
    json message{{"id", id}, {"method", method}, {"params", params}};
    if (!session.empty()) message["sessionId"] = session;
    const std::string text = message.dump() + std::string(1, '\0');
    if (::write(write_fd_, text.data(), text.size()) != static_cast<ssize_t>(text.size()))
      throw std::runtime_error("chromium pipe closed");
    const auto deadline = Clock::now() + 20s;
    while (Clock::now() < deadline) {
      json m = next(deadline);
      if (m.is_null()) break;
      if (m.contains("id") && m["id"] == id) {
        if (m.contains("error")) throw std::runtime_error(method + ": " + m["error"].dump());
        return m["result"];
      }
      events.push_back(std::move(m));
    }
    throw std::runtime_error(method + ": no answer from chromium");
  }

  std::vector<json> events;

 private:
  json next(Clock::time_point deadline) {
    for (;;) {
      const auto nul = buffer_.find('\0');
      if (nul != std::string::npos) {
        json m = json::parse(buffer_.substr(0, nul));
        buffer_.erase(0, nul + 1);
        return m;
      }
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0) return nullptr;
      pollfd p{read_fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>(left)) != 1) return nullptr;
      char chunk[65536];
      const auto n = ::read(read_fd_, chunk, sizeof chunk);
      if (n <= 0) return nullptr;
      buffer_.append(chunk, static_cast<std::size_t>(n));
    }
  }
  pid_t pid_ = -1;
  int write_fd_ = -1, read_fd_ = -1;
  int next_id_ = 1;
  std::string buffer_;
};

json evaluate(Chromium& c, const std::string& session, const std::string& expression) {
  const auto r = c.call("Runtime.evaluate", {{"expression", expression}, {"returnByValue", true}}, session);
  return r["result"].value("value", json());
}

/// The recording's column of a stream channel: the name itself or with its unit suffix.
std::optional<std::size_t> column_of(const Recording& rec, const std::string& channel) {
  for (std::size_t i = 0; i < rec.columns.size(); ++i) {
    if (rec.columns[i] == channel || rec.columns[i].rfind(channel + "_", 0) == 0) return i;
  }
  return std::nullopt;
}

TEST(ScopeBrowser, PageHoldsTheRunsSamplesWithNoNetwork) {
  ASSERT_TRUE(fs::exists("/usr/bin/chromium")) << "Debian's chromium is needed (scripts/install-deps.sh)";
  TempDir dir;
  Daemon d(dir,
           "[loop]\nperiod = \"1ms\"\nclock = \"real\"\noverrun_limit = 0\n[device]\ndriver = \"loopback\"\n"
           "[device.loopback]\nmotion = \"rotary\"\n"
           "hand = \"mode=hold trajectory=sine amplitude=0.3 frequency=0.5\"\n"
           "[scene]\nname = \"spring-wheel\"\nintegrator = \"exact\"\n",
           {"--record", "run.csv"});
  ASSERT_TRUE(d.running()) << d.log();

  const fs::path scope_log = dir.path / "scope.log";
  const pid_t scope = start({hapticctl_binary().string(), "scope", "--no-browser", "--rate", "200",
                             "--socket", d.socket().string()},
                            scope_log);
  std::string url;
  for (int i = 0; i < 400 && url.empty(); ++i) {
    const auto text = slurp(scope_log);
    const auto at = text.find("http://127.0.0.1:");
    if (at != std::string::npos && text.find('/', at + 17) != std::string::npos)
      url = text.substr(at, text.find('/', at + 17) + 1 - at);
    std::this_thread::sleep_for(25ms);
  }
  ASSERT_FALSE(url.empty()) << slurp(scope_log);

  json samples, page_status;
  std::string html;
  std::vector<std::string> requests;
  {
    Chromium chromium(dir.path);
    const auto target = chromium.call("Target.createTarget", {{"url", "about:blank"}});
    const std::string session = chromium.call(
        "Target.attachToTarget", {{"targetId", target["targetId"]}, {"flatten", true}})["sessionId"];
    chromium.call("Network.enable", {}, session);
    chromium.call("Page.enable", {}, session);
    chromium.call("Page.navigate", {{"url", url}}, session);
    // Three seconds of the stream at 200 Hz, and the status panel filled.
    const auto deadline = Clock::now() + 30s;
    while (Clock::now() < deadline) {
      const auto n = evaluate(chromium, session, "window.hapticdScope ? hapticdScope.samples.length : -1");
      const auto scene = evaluate(chromium, session, "document.getElementById('scene-name').textContent");
      if (n.is_number() && n.get<int>() >= 600 && scene == "spring-wheel") break;
      std::this_thread::sleep_for(200ms);
    }
    std::this_thread::sleep_for(300ms);  // one more redraw of the plots for the picture
    const auto shot = chromium.call("Page.captureScreenshot", {{"format", "png"}}, session);
    const std::string png = base64_decode(shot["data"].get<std::string>());
    std::ofstream(dir.path / "scope.png", std::ios::binary) << png;
    if (const char* keep = std::getenv("HAPTICD_SCOPE_SCREENSHOT"))
      std::ofstream(keep, std::ios::binary) << png;
    EXPECT_GT(png.size(), 10000u);
    samples =
        json::parse(evaluate(chromium, session, "JSON.stringify(hapticdScope.samples)").get<std::string>());
    page_status = evaluate(chromium, session,
                           "({scene: document.getElementById('scene-name').textContent,"
                           " stability: document.getElementById('stability-badge').textContent,"
                           " verdict: document.getElementById('stability').textContent,"
                           " fault: document.getElementById('fault-state').textContent,"
                           " parameters: document.getElementById('parameters').rows.length,"
                           " plots: document.querySelectorAll('.plot canvas').length,"
                           " resources: performance.getEntriesByType('resource').map((e) => e.name)})");
    html = evaluate(chromium, session, "document.documentElement.outerHTML").get<std::string>();
    for (const auto& e : chromium.events) {
      if (e.value("method", "") == "Network.requestWillBeSent")
        requests.push_back(e["params"]["request"]["url"]);
    }
  }
  end(scope, SIGINT);
  ASSERT_EQ(d.stop(), 0) << d.log();
  const auto rec = read_recording(dir.path / "run.csv");

  // No network: every request went to the hapticctl that served the page.
  ASSERT_FALSE(requests.empty());
  for (const auto& r : requests) EXPECT_EQ(r.rfind(url, 0), 0u) << r;
  for (const auto& r : page_status["resources"]) EXPECT_EQ(r.get<std::string>().rfind(url, 0), 0u) << r;
  EXPECT_EQ(html.find("://"), std::string::npos) << "the page names a URL";

  // The scene, its verdict and the fault state are shown.
  EXPECT_EQ(page_status["scene"], "spring-wheel") << page_status.dump();
  EXPECT_EQ(page_status["stability"], "stable") << page_status.dump();
  EXPECT_FALSE(page_status["verdict"].get<std::string>().empty());
  EXPECT_EQ(page_status["fault"], "running");
  EXPECT_GE(page_status["parameters"].get<int>(), 3);
  EXPECT_GE(page_status["plots"].get<int>(), 3) << "position, command, applied plotted";

  // The samples the page holds equal the recording's rows of their cycles.
  ASSERT_GE(samples.size(), 600u);
  std::map<std::uint64_t, std::size_t> rows;
  const auto cycle_column = rec.column("cycle");
  for (std::size_t i = 0; i < rec.rows.size(); ++i)
    rows[static_cast<std::uint64_t>(rec.rows[i][cycle_column])] = i;
  std::uint64_t last = 0;
  std::size_t compared = 0;
  for (const auto& s : samples) {
    const auto cycle = s["cycle"].get<std::uint64_t>();
    EXPECT_GT(cycle, last);
    last = cycle;
    const auto row = rows.find(cycle);
    ASSERT_NE(row, rows.end()) << "cycle " << cycle << " not recorded";
    for (const auto& [name, value] : s.items()) {
      if (name == "cycle") continue;
      const auto column = column_of(rec, name);
      ASSERT_TRUE(column) << name;
      ASSERT_TRUE(value.is_number()) << name << " " << value.dump();
      EXPECT_EQ(value.get<double>(), rec.rows[row->second][*column]) << name << " at cycle " << cycle;
      ++compared;
    }
  }
  EXPECT_GE(compared, samples.size() * 7);  // time_s, position, command, applied, latency_s, compute_s, flags
}

}  // namespace
}  // namespace hapticd::e2e::scope_browser_test
