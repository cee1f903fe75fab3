#pragma once
// End-to-end test support: start the real hapticd binary as a subprocess,
// drive it with the real hapticctl binary, and read its CSV recordings.

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace hapticd::e2e {

std::filesystem::path hapticd_binary();
std::filesystem::path hapticctl_binary();

/// A temporary directory removed at destruction.
struct TempDir {
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::filesystem::path path;
};

struct CommandResult {
  int exit_code = -1;
  std::string out;
  std::string err;
};

/// Runs a program to completion, capturing stdout and stderr.
CommandResult run(const std::filesystem::path& program, const std::vector<std::string>& args,
                  std::chrono::seconds timeout = std::chrono::seconds(60));

/// hapticd started with a config file; stopped with SIGTERM at destruction.
class Daemon {
 public:
  /// Writes `config_toml` to dir/hapticd.toml (its [control] socket and
  /// [recorder] directory are set to dir) and starts hapticd on it.
  /// launcher: a command line hapticd is run under (hapticd and its
  /// arguments are appended), e.g. to give it its own mount namespace.
  Daemon(const TempDir& dir, const std::string& config_toml, std::vector<std::string> extra_args = {},
         std::vector<std::string> launcher = {});
  ~Daemon();
  Daemon(const Daemon&) = delete;
  Daemon& operator=(const Daemon&) = delete;

  const std::filesystem::path& socket() const { return socket_; }
  /// hapticctl --socket <socket> args...
  CommandResult ctl(std::vector<std::string> args) const;
  /// Sends SIGTERM and waits; returns the exit status (or -signal).
  int stop(std::chrono::seconds timeout = std::chrono::seconds(20));
  /// Waits for the process to exit by itself (e.g. [loop] duration); returns its status.
  int wait(std::chrono::seconds timeout = std::chrono::seconds(120));
  std::string log() const;  ///< everything hapticd printed so far (stdout+stderr)
  bool running() const;
  pid_t pid() const { return pid_; }  ///< the process started (hapticd, or the launcher exec'ing it)

 private:
  std::filesystem::path dir_;
  std::filesystem::path socket_;
  std::filesystem::path log_;
  pid_t pid_ = -1;
  int status_ = -1;
};

/// A raw connection to a socket, for sending what hapticctl never would.
class RawConnection {
 public:
  explicit RawConnection(const std::filesystem::path& socket);  ///< throws if it cannot connect
  ~RawConnection();
  RawConnection(const RawConnection&) = delete;
  RawConnection& operator=(const RawConnection&) = delete;
  bool send(const std::string& bytes);  ///< false when the peer is gone
  /// The next '\n'-terminated line without it; "" on timeout or end of input.
  std::string read_line(std::chrono::milliseconds timeout = std::chrono::seconds(10));
  int fd() const { return fd_; }

 private:
  int fd_ = -1;
  std::string buffer_;
};

/// A CSV recording: '# key: value' header lines, one column-name line, numbers.
struct Recording {
  std::map<std::string, std::string> header;
  std::vector<std::string> comments;  ///< every '#' line, in order
  std::vector<std::string> columns;
  std::vector<std::vector<double>> rows;
  std::size_t column(const std::string& name) const;  ///< throws if absent
  bool has_column(const std::string& name) const;
  std::vector<double> values(const std::string& name) const;
};
Recording read_recording(const std::filesystem::path& csv);

}  // namespace hapticd::e2e
