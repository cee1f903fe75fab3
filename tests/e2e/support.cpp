#include "support.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

namespace hapticd::e2e {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

fs::path hapticd_binary() { return fs::path(HAPTICD_BINARY_DIR) / "daemon" / "hapticd"; }
fs::path hapticctl_binary() { return fs::path(HAPTICD_BINARY_DIR) / "cli" / "hapticctl"; }

TempDir::TempDir() {
  std::string pattern = (fs::temp_directory_path() / "hapticd-e2e-XXXXXX").string();
  if (mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
  path = pattern;
}
TempDir::~TempDir() {
  std::error_code ec;
  if (std::getenv("HAPTICD_KEEP_TEST_DIRS") == nullptr) fs::remove_all(path, ec);
}

namespace {

std::string slurp(const fs::path& file) {
  std::ifstream in(file);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

pid_t spawn(const fs::path& program, const std::vector<std::string>& args, const fs::path& out,
            const fs::path& err) {
  const pid_t pid = fork();
  if (pid < 0) throw std::runtime_error("fork failed");
  if (pid == 0) {
    const int out_fd = open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int err_fd = out == err ? out_fd : open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int null_fd = open("/dev/null", O_RDONLY);
    dup2(null_fd, 0);
    dup2(out_fd, 1);
    dup2(err_fd, 2);
    std::vector<char*> argv;
    std::string name = program.string();
    argv.push_back(name.data());
    std::vector<std::string> copy = args;
    for (auto& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv(name.c_str(), argv.data());
    _exit(127);
  }
  return pid;
}

int decode(int status) {
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return -WTERMSIG(status);
  return -1000;
}

bool wait_for(pid_t pid, int& status, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    const pid_t r = waitpid(pid, &status, WNOHANG);
    if (r == pid) return true;
    std::this_thread::sleep_for(5ms);
  }
  return false;
}

}  // namespace

CommandResult run(const fs::path& program, const std::vector<std::string>& args,
                  std::chrono::seconds timeout) {
  TempDir dir;
  const fs::path out = dir.path / "out";
  const fs::path err = dir.path / "err";
  const pid_t pid = spawn(program, args, out, err);
  int status = 0;
  if (!wait_for(pid, status, timeout)) {
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
    throw std::runtime_error(program.string() + " timed out");
  }
  return {decode(status), slurp(out), slurp(err)};
}

Daemon::Daemon(const TempDir& dir, const std::string& config_toml, std::vector<std::string> extra_args,
               std::vector<std::string> launcher)
    : dir_(dir.path), socket_(dir.path / "hapticd.sock"), log_(dir.path / "hapticd.log") {
  std::string config = config_toml;
  if (config.find("[control]") == std::string::npos) {
    config += "\n[control]\nsocket = \"" + socket_.string() + "\"\n";
  }
  if (config.find("[recorder]") == std::string::npos) {
    config += "\n[recorder]\ndirectory = \"" + dir_.string() + "\"\n";
  }
  const fs::path config_path = dir_ / "hapticd.toml";
  std::ofstream(config_path) << config;
  std::vector<std::string> args{"--config", config_path.string()};
  args.insert(args.end(), extra_args.begin(), extra_args.end());
  // $HAPTICD_E2E_SANDBOX: a launcher put right before hapticd (after the
  // test's own), e.g. "sandbox_exec POLICY --": the unit's system call filter
  // (tests/systemd.cmake's sandboxed runs).
  if (const char* sandbox = std::getenv("HAPTICD_E2E_SANDBOX"); sandbox != nullptr && *sandbox != '\0') {
    std::istringstream words(sandbox);
    for (std::string word; words >> word;) launcher.push_back(word);
  }
  if (launcher.empty()) {
    pid_ = spawn(hapticd_binary(), args, log_, log_);
  } else {
    std::vector<std::string> full(launcher.begin() + 1, launcher.end());
    full.push_back(hapticd_binary().string());
    full.insert(full.end(), args.begin(), args.end());
    pid_ = spawn(launcher.front(), full, log_, log_);
  }
  // Ready when the socket answers `status`, or when the process has exited.
  const auto deadline = std::chrono::steady_clock::now() + 20s;
  while (std::chrono::steady_clock::now() < deadline) {
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) == pid_) {
      status_ = decode(status);
      pid_ = -1;
      return;
    }
    if (fs::exists(socket_) && ctl({"status"}).exit_code == 0) return;
    std::this_thread::sleep_for(20ms);
  }
  throw std::runtime_error("hapticd did not become ready: " + log());
}

Daemon::~Daemon() {
  if (pid_ > 0) {
    kill(pid_, SIGKILL);
    int status = 0;
    waitpid(pid_, &status, 0);
  }
}

CommandResult Daemon::ctl(std::vector<std::string> args) const {
  args.insert(args.begin(), {"--socket", socket_.string()});
  return run(hapticctl_binary(), args);
}

int Daemon::stop(std::chrono::seconds timeout) {
  if (pid_ <= 0) return status_;
  kill(pid_, SIGTERM);
  int status = 0;
  if (!wait_for(pid_, status, timeout)) {
    kill(pid_, SIGKILL);
    waitpid(pid_, &status, 0);
    pid_ = -1;
    return status_ = -1000;
  }
  pid_ = -1;
  return status_ = decode(status);
}

int Daemon::wait(std::chrono::seconds timeout) {
  if (pid_ <= 0) return status_;
  int status = 0;
  if (!wait_for(pid_, status, timeout)) return -2000;
  pid_ = -1;
  return status_ = decode(status);
}

std::string Daemon::log() const { return slurp(log_); }

bool Daemon::running() const {
  if (pid_ <= 0) return false;
  return kill(pid_, 0) == 0;
}

RawConnection::RawConnection(const fs::path& socket) {
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  const std::string text = socket.string();
  if (text.size() >= sizeof addr.sun_path) throw std::runtime_error("socket path too long: " + text);
  std::memcpy(addr.sun_path, text.c_str(), text.size() + 1);
  fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd_ < 0 || ::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    if (fd_ >= 0) ::close(fd_);
    throw std::runtime_error("cannot connect to " + text + ": " + std::strerror(errno));
  }
}

RawConnection::~RawConnection() { ::close(fd_); }

bool RawConnection::send(const std::string& bytes) {
  std::size_t sent = 0;
  while (sent < bytes.size()) {
    const ssize_t n = ::send(fd_, bytes.data() + sent, bytes.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) return false;
    sent += static_cast<std::size_t>(n);
  }
  return true;
}

std::string RawConnection::read_line(std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    if (const auto nl = buffer_.find('\n'); nl != std::string::npos) {
      std::string line = buffer_.substr(0, nl);
      buffer_.erase(0, nl + 1);
      return line;
    }
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return "";
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, static_cast<int>(left.count())) <= 0) return "";
    char chunk[65536];
    const ssize_t n = ::recv(fd_, chunk, sizeof chunk, 0);
    if (n <= 0) return "";
    buffer_.append(chunk, static_cast<std::size_t>(n));
  }
}

std::size_t Recording::column(const std::string& name) const {
  for (std::size_t i = 0; i < columns.size(); ++i) {
    if (columns[i] == name) return i;
  }
  throw std::runtime_error("no column '" + name + "' in the recording");
}

bool Recording::has_column(const std::string& name) const {
  for (const auto& c : columns) {
    if (c == name) return true;
  }
  return false;
}

std::vector<double> Recording::values(const std::string& name) const {
  const std::size_t i = column(name);
  std::vector<double> v;
  v.reserve(rows.size());
  for (const auto& row : rows) v.push_back(row.at(i));
  return v;
}

Recording read_recording(const fs::path& csv) {
  std::ifstream in(csv);
  if (!in) throw std::runtime_error("cannot open recording " + csv.string());
  Recording rec;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    if (line[0] == '#') {
      rec.comments.push_back(line);
      const auto colon = line.find(':');
      if (colon != std::string::npos) {
        std::string key = line.substr(1, colon - 1);
        while (!key.empty() && key.front() == ' ') key.erase(key.begin());
        std::string value = line.substr(colon + 1);
        while (!value.empty() && value.front() == ' ') value.erase(value.begin());
        rec.header[key] = value;
      }
      continue;
    }
    std::vector<std::string> cells;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) cells.push_back(cell);
    if (rec.columns.empty()) {
      rec.columns = cells;
      continue;
    }
    if (cells == rec.columns) continue;  // a repeated header after a scene switch
    std::vector<double> row;
    row.reserve(cells.size());
    for (const auto& c : cells) row.push_back(std::strtod(c.c_str(), nullptr));
    rec.rows.push_back(std::move(row));
  }
  return rec;
}

}  // namespace hapticd::e2e
