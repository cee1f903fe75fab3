#include "daemon/config/host_checks.hpp"

#include <grp.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>
#include <system_error>
#include <vector>

#include "client/socket_path.hpp"
#include "world/text.hpp"

namespace hapticd::daemon::config {

namespace {

using world::text::errno_text;

std::string quoted(const std::string& text) { return "\"" + text + "\""; }

std::string_view file_kind(mode_t mode) {
  if (S_ISREG(mode)) return "a regular file";
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISLNK(mode)) return "a symbolic link";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode) || S_ISBLK(mode)) return "a device node";
  return "not a socket";
}

/// Why files cannot be created in `dir`, or "" if they can.
std::string directory_problem(const std::filesystem::path& dir) {
  struct stat st {};
  if (::stat(dir.c_str(), &st) != 0) {
    const int error = errno;
    if (error == ENOENT) return "directory " + dir.string() + " does not exist";
    return "directory " + dir.string() + ": " + errno_text(error);
  }
  if (!S_ISDIR(st.st_mode))
    return dir.string() + " is " + std::string(file_kind(st.st_mode)) + ", not a directory";
  if (::access(dir.c_str(), W_OK | X_OK) != 0) {
    return "cannot create files in " + dir.string() + ": " + errno_text(errno);
  }
  return {};
}

void check_socket(const ControlConfig& control) {
  const std::string accepted =
      "; accepted: \"\" (the default path) or a path in an existing directory the daemon can create files "
      "in, free or holding a stale hapticd socket";
  // The path the control server will bind: the default one for "".
  const std::string resolved = client::resolve_socket_path(control.socket);
  std::string what = "control.socket = " + quoted(control.socket);
  if (control.socket.empty()) what += " (" + resolved + ")";
  what += ": ";
  const std::filesystem::path path(resolved);
  std::filesystem::path dir = path.parent_path();
  if (dir.empty()) dir = ".";
  if (const std::string problem = directory_problem(dir); !problem.empty()) {
    throw ConfigError(control.socket_where, "control.socket", what + problem + accepted);
  }
  struct stat st {};
  if (::lstat(path.c_str(), &st) == 0 && !S_ISSOCK(st.st_mode)) {
    throw ConfigError(control.socket_where, "control.socket",
                      what + resolved + " is " + std::string(file_kind(st.st_mode)) +
                          ", not a socket (hapticd never replaces it)" + accepted);
  }
}

void check_group(const ControlConfig& control) {
  if (control.group.empty()) return;
  group entry{};
  group* found = nullptr;
  std::vector<char> buffer(4096);
  int error = 0;
  while ((error = ::getgrnam_r(control.group.c_str(), &entry, buffer.data(), buffer.size(), &found)) ==
             ERANGE &&
         buffer.size() < (1U << 20)) {
    buffer.resize(buffer.size() * 2);
  }
  if (found != nullptr) return;
  const std::string what = "control.group = " + quoted(control.group) + ": ";
  const std::string accepted =
      "; accepted: \"\" (only the daemon's user may change things) or the name of an existing group";
  const std::string problem =
      error == 0 ? "no such group on this host" : "group lookup failed: " + errno_text(error);
  throw ConfigError(control.group_where, "control.group", what + problem + accepted);
}

void check_recording_directory(const RecorderConfig& recorder, const char* state_directory_env) {
  const std::filesystem::path dir = resolve_recording_directory(recorder, state_directory_env);
  std::string what = "recorder.directory = " + quoted(recorder.directory);
  if (recorder.directory.empty()) what += " (" + dir.string() + ")";
  what += ": ";
  const std::string accepted =
      "; accepted: \"\" ($STATE_DIRECTORY/recordings under systemd, else .) or a directory the daemon can "
      "create files in (created if missing)";
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    throw ConfigError(recorder.directory_where, "recorder.directory",
                      what + "cannot create " + dir.string() + ": " + ec.message() + accepted);
  }
  if (const std::string problem = directory_problem(dir); !problem.empty()) {
    throw ConfigError(recorder.directory_where, "recorder.directory", what + problem + accepted);
  }
}

/// [device] origin = "persist": the origin file's directory is created if
/// missing and must take new files (the file is written by a rename there).
void check_origin_file(const DeviceConfig& device, const char* state_directory_env) {
  if (device.origin_keeping() != OriginKeeping::persist) return;
  const std::filesystem::path file = resolve_origin_file(device, state_directory_env);
  std::filesystem::path dir = file.parent_path();
  if (dir.empty()) dir = ".";
  std::string what = "device.origin_file = " + quoted(device.origin_file);
  if (device.origin_file.empty()) what += " (" + file.string() + ")";
  what += ": ";
  const std::string accepted =
      "; accepted: \"\" (origin.toml in $STATE_DIRECTORY under systemd, else in the working directory) or "
      "a file in a directory the daemon can create files in (created if missing), for [device] origin = "
      "\"persist\"";
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) {
    throw ConfigError(device.origin_file_where, "device.origin_file",
                      what + "cannot create " + dir.string() + ": " + ec.message() + accepted);
  }
  if (const std::string problem = directory_problem(dir); !problem.empty()) {
    throw ConfigError(device.origin_file_where, "device.origin_file", what + problem + accepted);
  }
}

}  // namespace

void check_host(const DaemonConfig& config, const char* state_directory_env) {
  check_socket(config.control);
  check_group(config.control);
  check_recording_directory(config.recorder, state_directory_env);
  check_origin_file(config.device, state_directory_env);
}

}  // namespace hapticd::daemon::config
