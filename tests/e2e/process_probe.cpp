#include "process_probe.hpp"

#include <algorithm>
#include <chrono>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>
#include <string>

namespace hapticd::e2e {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace std::chrono_literals;

ProcessUsage usage_of(pid_t pid) {
  ProcessUsage u;
  const fs::path proc = fs::path("/proc") / std::to_string(pid);
  std::error_code ec;
  int n = 0;
  for (fs::directory_iterator it(proc / "fd", ec), end; !ec && it != end; it.increment(ec)) ++n;
  if (!ec) u.fds = n;
  std::ifstream status(proc / "status");
  for (std::string line; std::getline(status, line);) {
    if (line.starts_with("VmRSS:")) u.rss_kib = std::stoll(line.substr(6));
  }
  return u;
}

ProcessUsage settled_usage(const Daemon& d, int fds) {
  const auto end = std::chrono::steady_clock::now() + 10s;
  ProcessUsage u = usage_of(d.pid());
  while (u.fds != fds && std::chrono::steady_clock::now() < end) {
    std::this_thread::sleep_for(50ms);
    u = usage_of(d.pid());
  }
  return u;
}

void reset_stats(const Daemon& d) {
  const auto r = d.ctl({"device", "call", "stats.reset"});
  if (r.exit_code != 0) throw std::runtime_error("stats.reset failed: " + r.err);
}

std::uint64_t overruns(const Daemon& d) {
  const auto r = d.ctl({"stats", "--json"});
  if (r.exit_code != 0) throw std::runtime_error("stats failed: " + r.err);
  return json::parse(r.out).at("overruns").get<std::uint64_t>();
}

double ProbeResult::within(double limit_ms) const {
  if (ms.empty()) return 0.0;
  const auto n = std::count_if(ms.begin(), ms.end(), [limit_ms](double v) { return v <= limit_ms; });
  return static_cast<double>(n) / static_cast<double>(ms.size());
}

Prober::Prober(const fs::path& socket) : connection_(socket) {
  thread_ = std::thread([this] {
    std::uint64_t id = 1;
    while (!stop_) {
      const auto t0 = std::chrono::steady_clock::now();
      const std::string request =
          R"({"jsonrpc":"2.0","id":)" + std::to_string(id++) + R"(,"method":"status"})" + "\n";
      const std::string reply = connection_.send(request) ? connection_.read_line(2s) : std::string();
      const double ms =
          std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      const json parsed = json::parse(reply, nullptr, false);
      if (!parsed.is_object() || !parsed.contains("result")) {
        ++result_.failures;
        if (reply.empty()) break;  // the connection is gone
      } else {
        ++result_.replies;
        result_.ms.push_back(ms);
        result_.max_ms = std::max(result_.max_ms, ms);
      }
      std::this_thread::sleep_for(20ms);
    }
  });
}

Prober::~Prober() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

ProbeResult Prober::finish() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  return result_;
}

}  // namespace hapticd::e2e
