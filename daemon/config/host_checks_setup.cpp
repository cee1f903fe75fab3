// hapticd --setup-check: the items in order, the paths of the config, and
// the report as text and JSON. daemon/config/host_checks_setup.hpp.

#include "daemon/config/host_checks_setup.hpp"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <sstream>

#include "daemon/config/host_checks.hpp"

namespace hapticd::daemon::config {

SetupItem check_paths(const DaemonConfig& config, const SetupContext& context) {
  SetupItem item{"paths", Verdict::ok, "", ""};
  try {
    check_host(config, context.state_directory_env);
  } catch (const ConfigError& e) {
    item.verdict = Verdict::fail;
    item.finding = e.what();
    item.fix = "the key it names: a directory the service user can create files in";
    return item;
  }
  const auto recordings = resolve_recording_directory(config.recorder, context.state_directory_env);
  item.finding = "control socket and recording directory " + recordings.string() + " usable";
  if (config.recorder.directory.empty() && context.state_directory_env == nullptr) {
    item.finding +=
        " (here; the service records to $STATE_DIRECTORY/recordings, /var/lib/hapticd/recordings)";
  }
  return item;
}

std::vector<SetupItem> run_setup_check(const DaemonConfig& config, const SetupFacts& facts,
                                       const SetupContext& context) {
  std::vector<SetupItem> items{check_rt_priority(config, facts, context), check_memlock(config, facts),
                               check_kernel(config, context), check_cpu_isolation(config, context),
                               check_dma_latency(facts, context)};
  for (auto& device : check_device(config, facts, context)) items.push_back(std::move(device));
  items.push_back(check_paths(config, context));
  return items;
}

Verdict overall(const std::vector<SetupItem>& items) noexcept {
  Verdict worst = Verdict::ok;
  for (const auto& i : items) {
    if (i.verdict == Verdict::fail) return Verdict::fail;
    if (i.verdict == Verdict::warning) worst = Verdict::warning;
  }
  return worst;
}

namespace {

std::array<int, 3> counts(const std::vector<SetupItem>& items) {
  std::array<int, 3> n{};
  for (const auto& i : items) ++n[static_cast<std::size_t>(i.verdict)];
  return n;
}

}  // namespace

nlohmann::json to_json(const DaemonConfig& config, const SetupFacts& facts,
                       const std::vector<SetupItem>& items) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& i : items) {
    list.push_back({{"name", i.name},
                    {"verdict", std::string(to_string(i.verdict))},
                    {"finding", i.finding},
                    {"fix", i.fix}});
  }
  const auto n = counts(items);
  return {{"config", config.source},
          {"driver", config.device.driver},
          {"period_s", config.loop.period_s},
          {"service_user", facts.user.name},
          {"verdict", std::string(to_string(overall(items)))},
          {"counts", {{"ok", n[0]}, {"warning", n[1]}, {"fail", n[2]}}},
          {"items", list}};
}

std::string to_text(const DaemonConfig& config, const SetupFacts& facts,
                    const std::vector<SetupItem>& items) {
  std::ostringstream out;
  out << "hapticd setup check: " << config.source << " (driver " << config.device.driver << ", period "
      << config.loop.period_s * 1e3 << " ms), service user " << facts.user.name << "\n";
  for (const auto& i : items) {
    std::string verdict(to_string(i.verdict));
    verdict.resize(8, ' ');
    std::string name = i.name;
    name.resize(16, ' ');
    out << "  " << verdict << name << i.finding << "\n";
    if (!i.fix.empty()) out << "  " << std::string(24, ' ') << "fix: " << i.fix << "\n";
  }
  const auto n = counts(items);
  out << n[0] << " ok, " << n[1] << " warnings, " << n[2] << " failures\n";
  return out.str();
}

std::optional<std::string> run_ip_details(const std::string& interface) {
  int pipe_fds[2];
  if (::pipe(pipe_fds) != 0) return std::nullopt;
  const pid_t pid = ::fork();
  if (pid < 0) return std::nullopt;
  if (pid == 0) {
    ::dup2(pipe_fds[1], 1);
    ::close(pipe_fds[0]);
    ::close(pipe_fds[1]);
    if (const int null = ::open("/dev/null", O_WRONLY); null >= 0) ::dup2(null, 2);
    ::execlp("ip", "ip", "-details", "-json", "link", "show", "dev", interface.c_str(), nullptr);
    ::_exit(127);
  }
  ::close(pipe_fds[1]);
  std::string text;
  std::array<char, 4096> buffer{};
  ssize_t n = 0;
  while ((n = ::read(pipe_fds[0], buffer.data(), buffer.size())) > 0)
    text.append(buffer.data(), static_cast<std::size_t>(n));
  ::close(pipe_fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) return std::nullopt;
  return text;
}

}  // namespace hapticd::daemon::config
