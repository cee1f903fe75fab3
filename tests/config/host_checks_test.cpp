// config::check_host: what the config names on this host (socket directory
// and path, group, recording directory) is checked before anything starts,
// and refused at the key's file:line:column with what is accepted.
#include "daemon/config/host_checks.hpp"

#include <grp.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

namespace hapticd::daemon::config::host_checks_test {
namespace {

namespace fs = std::filesystem;

struct TempDir {
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "hapticd-host-XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    path = pattern;
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  fs::path path;
};

/// A config whose [control] and [recorder] are written at known lines:
/// socket at 2:10, group at 3:9, directory at 5:13.
DaemonConfig config_with(const std::string& socket, const std::string& group, const std::string& directory) {
  return parse_config("[control]\nsocket = \"" + socket + "\"\ngroup = \"" + group +
                          "\"\n[recorder]\ndirectory = \"" + directory + "\"\n",
                      "h.toml");
}

/// check_host's error, or "no error".
std::string error_of(const DaemonConfig& config, std::string* key = nullptr) {
  try {
    check_host(config, nullptr);
  } catch (const ConfigError& e) {
    if (key != nullptr) *key = e.key();
    return e.what();
  }
  return "no error";
}

TEST(HostChecks, ValidPathsAndGroupPass) {
  TempDir dir;
  EXPECT_EQ(error_of(config_with((dir.path / "s.sock").string(), "root", dir.path.string())), "no error");
  EXPECT_EQ(error_of(config_with("", "", dir.path.string())), "no error");  // "" = defaults
}

TEST(HostChecks, MissingSocketDirectoryIsRefusedAtTheKey) {
  TempDir dir;
  const std::string socket = (dir.path / "missing" / "s.sock").string();
  std::string key;
  EXPECT_EQ(error_of(config_with(socket, "", dir.path.string()), &key),
            "h.toml:2:10: control.socket = \"" + socket + "\": directory " + (dir.path / "missing").string() +
                " does not exist; accepted: \"\" (the default path) or a path in an existing directory the "
                "daemon can create files in, free or holding a stale hapticd socket");
  EXPECT_EQ(key, "control.socket");
  // A regular file where the directory should be.
  std::ofstream(dir.path / "file") << "x";
  const std::string under_file = (dir.path / "file" / "s.sock").string();
  const std::string message = error_of(config_with(under_file, "", dir.path.string()));
  EXPECT_EQ(message.rfind("h.toml:2:10: control.socket = ", 0), 0u) << message;
  EXPECT_NE(message.find("is a regular file, not a directory"), std::string::npos) << message;
}

TEST(HostChecks, DefaultSocketPathIsCheckedWhereItWillBeBound) {
  // "" binds $RUNTIME_DIRECTORY/hapticd.sock, else $XDG_RUNTIME_DIR/hapticd.sock, else
  // /tmp/hapticd-$UID.sock.
  TempDir dir;
  const char* runtime = std::getenv("RUNTIME_DIRECTORY");
  const std::string saved = runtime != nullptr ? runtime : "";
  const fs::path missing = dir.path / "run" / "user";
  ::setenv("RUNTIME_DIRECTORY", missing.c_str(), 1);
  const std::string message =
      error_of(parse_config("[recorder]\ndirectory = \"" + dir.path.string() + "\"\n", "d.toml"));
  if (runtime != nullptr) {
    ::setenv("RUNTIME_DIRECTORY", saved.c_str(), 1);
  } else {
    ::unsetenv("RUNTIME_DIRECTORY");
  }
  EXPECT_EQ(message.rfind("d.toml: control.socket = \"\" (" + (missing / "hapticd.sock").string() +
                              "): directory " + missing.string() + " does not exist; accepted: ",
                          0),
            0u)
      << message;
}

TEST(HostChecks, SocketPathThatIsARegularFileIsRefused) {
  TempDir dir;
  const fs::path file = dir.path / "not-a-socket";
  std::ofstream(file) << "precious";
  EXPECT_EQ(error_of(config_with(file.string(), "", dir.path.string())),
            "h.toml:2:10: control.socket = \"" + file.string() + "\": " + file.string() +
                " is a regular file, not a socket (hapticd never replaces it); accepted: \"\" (the default "
                "path) or a path in an existing directory the daemon can create files in, free or holding a "
                "stale hapticd socket");
  const fs::path subdir = dir.path / "a-directory";
  fs::create_directory(subdir);
  const std::string message = error_of(config_with(subdir.string(), "", dir.path.string()));
  EXPECT_NE(message.find("is a directory, not a socket"), std::string::npos) << message;
}

TEST(HostChecks, AnExistingSocketPasses) {
  // A stale socket (no daemon behind it): the control server replaces it.
  TempDir dir;
  const fs::path path = dir.path / "stale.sock";
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::strncpy(address.sun_path, path.c_str(), sizeof address.sun_path - 1);
  ASSERT_EQ(::bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address), 0);
  ::close(fd);
  EXPECT_EQ(error_of(config_with(path.string(), "", dir.path.string())), "no error");
}

TEST(HostChecks, UnknownGroupIsRefusedAtTheKey) {
  TempDir dir;
  std::string key;
  EXPECT_EQ(error_of(config_with("", "hapticd-no-such-group", dir.path.string()), &key),
            "h.toml:3:9: control.group = \"hapticd-no-such-group\": no such group on this host; accepted: "
            "\"\" (only the daemon's user may change things) or the name of an existing group");
  EXPECT_EQ(key, "control.group");
}

TEST(HostChecks, RecordingDirectoryIsCreatedWhenItCanBe) {
  TempDir dir;
  const fs::path nested = dir.path / "a" / "b";
  EXPECT_EQ(error_of(config_with("", "", nested.string())), "no error");
  EXPECT_TRUE(fs::is_directory(nested));
}

TEST(HostChecks, RecordingDirectoryThatCannotExistIsRefusedAtTheKey) {
  TempDir dir;
  std::ofstream(dir.path / "file") << "x";
  const std::string under_file = (dir.path / "file" / "recordings").string();
  std::string key;
  const std::string message = error_of(config_with("", "", under_file), &key);
  EXPECT_EQ(message, "h.toml:5:13: recorder.directory = \"" + under_file + "\": cannot create " + under_file +
                         ": Not a directory; accepted: \"\" ($STATE_DIRECTORY/recordings under systemd, else "
                         ".) or a directory the daemon can create files in (created if missing)");
  EXPECT_EQ(key, "recorder.directory");
  // The directory is a regular file itself.
  const std::string file = (dir.path / "file").string();
  const std::string is_file = error_of(config_with("", "", file));
  EXPECT_EQ(is_file.rfind("h.toml:5:13: recorder.directory = ", 0), 0u) << is_file;
}

/// check_host's error as uid/gid 65534 (nobody) when running as root (root
/// may write anywhere), else as ourselves.
std::string error_as_unprivileged(const DaemonConfig& config) {
  if (::geteuid() != 0) return error_of(config);
  int fds[2];
  if (::pipe(fds) != 0) return "pipe failed";
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(fds[0]);
    if (::setgroups(0, nullptr) != 0 || ::setgid(65534) != 0 || ::setuid(65534) != 0) ::_exit(121);
    const std::string message = error_of(config);
    const ssize_t n = ::write(fds[1], message.data(), message.size());
    ::_exit(n == static_cast<ssize_t>(message.size()) ? 0 : 122);
  }
  ::close(fds[1]);
  std::string message;
  char chunk[1024];
  for (ssize_t n = 0; (n = ::read(fds[0], chunk, sizeof chunk)) > 0;)
    message.append(chunk, static_cast<std::size_t>(n));
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) return "child failed: " + std::to_string(status);
  return message;
}

TEST(HostChecks, UnwritableRecordingDirectoryIsRefused) {
  TempDir dir;
  fs::permissions(dir.path, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                fs::perms::others_read | fs::perms::others_exec);
  const fs::path locked = dir.path / "locked";
  fs::create_directory(locked);
  // r-x for everyone: the owner too when not root; root checks as nobody.
  fs::permissions(locked, fs::perms::owner_read | fs::perms::owner_exec | fs::perms::group_read |
                              fs::perms::group_exec | fs::perms::others_read | fs::perms::others_exec);
  const std::string message = error_as_unprivileged(config_with("", "", locked.string()));
  fs::permissions(locked, fs::perms::owner_all);
  EXPECT_EQ(message,
            "h.toml:5:13: recorder.directory = \"" + locked.string() + "\": cannot create files in " +
                locked.string() +
                ": Permission denied; accepted: \"\" ($STATE_DIRECTORY/recordings under systemd, else "
                ".) or a directory the daemon can create files in (created if missing)");
}

TEST(HostChecks, DefaultRecordingDirectoryIsNamedWithWhereItComesFrom) {
  TempDir dir;
  std::ofstream(dir.path / "state") << "x";  // $STATE_DIRECTORY is a file: recordings/ cannot exist
  const DaemonConfig config = parse_config("", "d.toml");
  const std::string state = (dir.path / "state").string();
  try {
    check_host(config, state.c_str());
    FAIL() << "accepted";
  } catch (const ConfigError& e) {
    const std::string message = e.what();
    EXPECT_EQ(
        message.rfind("d.toml: recorder.directory = \"\" (" + state + "/recordings): cannot create ", 0), 0u)
        << message;
  }
}

}  // namespace
}  // namespace hapticd::daemon::config::host_checks_test
