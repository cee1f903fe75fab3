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

SimulatedDrive::SimulatedDrive(const TempDir& dir, const std::string& hand, const std::string& plant,
                               const std::vector<std::string>& extra, int fifo_priority)
    : bus_(dir.path / "bus.sock"), log_(dir.path / "devsim.log") {
  int pipe_fds[2];
  if (pipe(pipe_fds) != 0) throw std::runtime_error("pipe failed");
  std::vector<std::string> args = {devsim_binary().string(),
                                   "canopen",
                                   "--listen",
                                   "unix:" + bus_.string(),
                                   "--plant",
                                   plant,
                                   "--hand",
                                   hand};
  args.insert(args.end(), extra.begin(), extra.end());
  pid_ = fork();
  if (pid_ == 0) {
    const int out = open(log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    dup2(pipe_fds[0], 0);
    dup2(out, 1);
    dup2(out, 2);
    close(pipe_fds[1]);
    if (fifo_priority > 0) {
      sched_param p{};
      p.sched_priority = fifo_priority;
      if (sched_setscheduler(0, SCHED_FIFO, &p) != 0) {
        static const char refused[] = "test: SCHED_FIFO refused, the drive runs as a normal process\n";
        (void)!write(2, refused, sizeof refused - 1);
      }
    }
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv(argv[0], argv.data());
    _exit(127);
  }
  close(pipe_fds[0]);
  commands_ = pipe_fds[1];
  // The drive prints "listening on" once its socket accepts: no handshake
  // but its log (it runs in its own process).
  const auto deadline = std::chrono::steady_clock::now() + 10s;
  while (log().find("listening on") == std::string::npos) {
    if (std::chrono::steady_clock::now() > deadline)
      throw std::runtime_error("devsim did not start: " + log());
    std::this_thread::sleep_for(10ms);
  }
}

SimulatedDrive::~SimulatedDrive() {
  if (commands_ >= 0) close(commands_);
  if (pid_ > 0) {
    kill(pid_, SIGTERM);
    int status = 0;
    waitpid(pid_, &status, 0);
  }
}

std::string SimulatedDrive::log() const {
  std::ifstream in(log_);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

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
