#include "tests/drivers/canopen/e2e/drive_process.hpp"

#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

namespace hapticd::e2e {

using namespace std::chrono_literals;

std::filesystem::path devsim_binary() {
  return std::filesystem::path(HAPTICD_BINARY_DIR) / "sim" / "devsim" / "hapticd-devsim";
}

namespace {

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// Forks and execs `args` with stdin from `stdin_fd` (-1: /dev/null), stdout
/// and stderr to `log`, SCHED_FIFO at `fifo_priority` if > 0; waits until
/// the log shows `ready` (throws after 10 s).
pid_t spawn(const std::vector<std::string>& args, const std::filesystem::path& log, int stdin_fd,
            int close_in_child, int fifo_priority, const std::string& ready) {
  const pid_t pid = fork();
  if (pid == 0) {
    const int out = open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int in = stdin_fd >= 0 ? stdin_fd : open("/dev/null", O_RDONLY);
    dup2(in, 0);
    dup2(out, 1);
    dup2(out, 2);
    if (close_in_child >= 0) close(close_in_child);
    if (fifo_priority > 0) {
      sched_param p{};
      p.sched_priority = fifo_priority;
      if (sched_setscheduler(0, SCHED_FIFO, &p) != 0) {
        static const char refused[] = "test: SCHED_FIFO refused, the drive runs as a normal process\n";
        (void)!write(2, refused, sizeof refused - 1);
      }
    }
    std::vector<std::string> copy = args;
    std::vector<char*> argv;
    for (auto& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  // No handshake but its log (it runs in its own process).
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (read_file(log).find(ready) == std::string::npos) {
    if (std::chrono::steady_clock::now() > deadline)
      throw std::runtime_error("devsim did not start: " + read_file(log));
    std::this_thread::sleep_for(10ms);
  }
  return pid;
}

}  // namespace

SimulatedDrive::SimulatedDrive(const TempDir& dir, const std::string& hand, const std::string& plant,
                               const std::vector<std::string>& extra, int fifo_priority)
    : SimulatedDrive(dir.path / "bus.sock", [&] {
        Spawn s{{devsim_binary().string(), "canopen", "--listen", "unix:" + (dir.path / "bus.sock").string(),
                 "--plant", plant, "--hand", hand},
                dir.path / "devsim.log",
                "listening on",
                fifo_priority};
        s.args.insert(s.args.end(), extra.begin(), extra.end());
        return s;
      }()) {}

SimulatedDrive::SimulatedDrive(std::filesystem::path bus, const Spawn& spawn_with)
    : bus_(std::move(bus)), log_(spawn_with.log) {
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) throw std::runtime_error("pipe failed");
  pid_ = spawn(spawn_with.args, log_, pipe_fds[0], pipe_fds[1], spawn_with.fifo_priority, spawn_with.ready);
  close(pipe_fds[0]);
  commands_ = pipe_fds[1];
}

std::unique_ptr<SimulatedDrive> SimulatedDrive::member(const TempDir& dir, const std::string& bus_interface,
                                                       int node, const std::string& hand,
                                                       const std::string& plant,
                                                       const std::vector<std::string>& extra,
                                                       int fifo_priority) {
  Spawn s{{devsim_binary().string(), "canopen", "--connect", bus_interface, "--node-id", std::to_string(node),
           "--plant", plant, "--hand", hand},
          dir.path / ("devsim-node" + std::to_string(node) + ".log"),
          "connected to the bus",
          fifo_priority};
  s.args.insert(s.args.end(), extra.begin(), extra.end());
  return std::unique_ptr<SimulatedDrive>(new SimulatedDrive(std::string(bus_interface.substr(5)), s));
}

SimulatedCanBus::SimulatedCanBus(const TempDir& dir, int fifo_priority)
    : bus_(dir.path / "bus.sock"), log_(dir.path / "canbus.log") {
  pid_ = spawn({devsim_binary().string(), "canbus", "--listen", "unix:" + bus_.string()}, log_, -1, -1,
               fifo_priority, "listening on");
}

SimulatedCanBus::~SimulatedCanBus() {
  if (pid_ > 0) {
    kill(pid_, SIGTERM);
    int status = 0;
    waitpid(pid_, &status, 0);
  }
}

std::string SimulatedCanBus::log() const { return read_file(log_); }

SimulatedDrive::~SimulatedDrive() {
  if (commands_ >= 0) close(commands_);
  if (pid_ > 0) {
    kill(pid_, SIGTERM);
    int status = 0;
    waitpid(pid_, &status, 0);
  }
}

std::string SimulatedDrive::log() const { return read_file(log_); }

std::string SimulatedDrive::command(const std::string& line) {
  const std::size_t before = replies().size();
  const std::string text = line + "\n";
  if (write(commands_, text.data(), text.size()) != static_cast<ssize_t>(text.size()))
    return "<write failed>";
  const auto deadline = std::chrono::steady_clock::now() + 5s;
  while (std::chrono::steady_clock::now() < deadline) {
    const auto r = replies();
    if (r.size() > before) return r.back();
    std::this_thread::sleep_for(2ms);
  }
  return "<no reply>";
}

void SimulatedDrive::kill_now() {
  kill(pid_, SIGKILL);
  int status = 0;
  waitpid(pid_, &status, 0);
  pid_ = -1;
}

std::vector<std::string> SimulatedDrive::replies() const {
  std::vector<std::string> lines;
  std::istringstream in(log());
  for (std::string l; std::getline(in, l);)
    if (l.rfind("ok ", 0) == 0 || l.rfind("error:", 0) == 0) lines.push_back(l);
  return lines;
}

}  // namespace hapticd::e2e
