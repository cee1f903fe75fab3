// Client library pieces that need no server: the socket path rule,
// connection failures, name=value parsing.

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "client/assignment.hpp"
#include "client/client.hpp"
#include "client/socket_path.hpp"
#include "control_test_util.hpp"

namespace client_test {

using namespace std::chrono_literals;
using hapticd::client::AssignmentError;
using hapticd::client::Client;
using hapticd::client::ConnectError;
using hapticd::client::parse_assignment;
using hapticd::client::parse_assignments;
using hapticd::client::parse_value;
using hapticd::client::ProtocolError;
using hapticd::client::resolve_socket_path;
using nlohmann::json;

namespace {

class EnvGuard {
 public:
  explicit EnvGuard(const char* name) : name_(name) {
    if (const char* v = std::getenv(name)) saved_ = v;
  }
  ~EnvGuard() {
    if (saved_)
      ::setenv(name_, saved_->c_str(), 1);
    else
      ::unsetenv(name_);
  }
  EnvGuard(const EnvGuard&) = delete;
  EnvGuard& operator=(const EnvGuard&) = delete;

 private:
  const char* name_;
  std::optional<std::string> saved_;
};

TEST(SocketPath, ResolutionOrder) {
  EnvGuard a("RUNTIME_DIRECTORY"), b("XDG_RUNTIME_DIR");
  ::setenv("RUNTIME_DIRECTORY", "/run/hapticd", 1);
  ::setenv("XDG_RUNTIME_DIR", "/run/user/1000", 1);
  EXPECT_EQ(resolve_socket_path("/etc/custom.sock"), "/etc/custom.sock");
  EXPECT_EQ(resolve_socket_path(), "/run/hapticd/hapticd.sock");
  ::setenv("RUNTIME_DIRECTORY", "/run/hapticd/:/run/other", 1);
  EXPECT_EQ(resolve_socket_path(), "/run/hapticd/hapticd.sock");
  ::unsetenv("RUNTIME_DIRECTORY");
  EXPECT_EQ(resolve_socket_path(), "/run/user/1000/hapticd.sock");
  ::setenv("XDG_RUNTIME_DIR", "", 1);
  EXPECT_EQ(resolve_socket_path(), "/tmp/hapticd-" + std::to_string(::geteuid()) + ".sock");
  ::unsetenv("XDG_RUNTIME_DIR");
  EXPECT_EQ(resolve_socket_path(), "/tmp/hapticd-" + std::to_string(::geteuid()) + ".sock");
}

TEST(SocketPath, ClientFindsTheDaemonItCanReach) {
  EnvGuard a("RUNTIME_DIRECTORY"), b("XDG_RUNTIME_DIR"), c("HAPTICD_SOCKET");
  hapticd::daemon::control::test::TempDir dir;
  ::unsetenv("RUNTIME_DIRECTORY");
  ::unsetenv("HAPTICD_SOCKET");
  ::setenv("XDG_RUNTIME_DIR", dir.path().c_str(), 1);
  using hapticd::client::resolve_client_socket_path;
  EXPECT_EQ(resolve_client_socket_path("/etc/custom.sock", "wheel"), "/etc/custom.sock");
  EXPECT_EQ(resolve_client_socket_path({}, "wheel"), "/run/hapticd/wheel/hapticd.sock");
  ::setenv("HAPTICD_SOCKET", "/srv/h.sock", 1);
  EXPECT_EQ(resolve_client_socket_path(), "/srv/h.sock");
  ::unsetenv("HAPTICD_SOCKET");
  // Nothing listens in $XDG_RUNTIME_DIR: the daemon's rule, unless the system
  // service's socket exists (not on a test machine: then the daemon's rule).
  const std::string own = (dir.path() / "hapticd.sock").string();
  const std::string expected =
      std::filesystem::exists("/run/hapticd/hapticd.sock") ? "/run/hapticd/hapticd.sock" : own;
  EXPECT_EQ(resolve_client_socket_path(), expected);
  // A daemon listening where the rule points wins.
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", own.c_str());
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  EXPECT_EQ(resolve_client_socket_path(), own);
  ::close(fd);
}

TEST(ClientConnect, MissingSocketIsConnectErrorNamingThePath) {
  hapticd::daemon::control::test::TempDir dir;
  std::string path = dir.file("absent.sock");
  try {
    Client::connect(path, 1s);
    FAIL() << "connected to nothing";
  } catch (const ConnectError& e) {
    EXPECT_EQ(e.error_number(), ENOENT);
    EXPECT_EQ(e.path(), path);
    EXPECT_EQ(std::string(e.what()),
              "hapticd is not running at " + path + " (connect: No such file or directory)");
  }
  EXPECT_THROW(Client::connect(std::string(200, 'x'), 1s), ConnectError);
}

// Issue 17, defect 3: with the daemon's listen backlog full (a connect
// flood), a non-blocking Unix connect() fails with EAGAIN and is not
// queued; the client took poll()'s "writable" for connected, and
// `hapticctl estop` failed with "send: Transport endpoint is not
// connected". It tries again until its timeout.
TEST(ClientConnect, AFullBacklogIsWaitedForNotTakenForConnected) {
  hapticd::daemon::control::test::TempDir dir;
  const std::string path = dir.file("full.sock");
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  path.copy(addr.sun_path, sizeof(addr.sun_path) - 1);
  const auto* where = reinterpret_cast<const sockaddr*>(&addr);
  const int listen_fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  ASSERT_EQ(::bind(listen_fd, where, sizeof(addr)), 0);
  ASSERT_EQ(::listen(listen_fd, 0), 0);
  std::vector<int> queued;  // fill the backlog
  for (int i = 0; i < 16; ++i) {
    const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
    if (::connect(fd, where, sizeof(addr)) != 0) {
      ::close(fd);
      break;
    }
    queued.push_back(fd);
  }
  ASSERT_FALSE(queued.empty());
  ASSERT_LT(queued.size(), 16u) << "the backlog never filled";
  try {
    Client::connect(path, 200ms);
    FAIL() << "an unconnected socket was taken for a connection";
  } catch (const ConnectError& e) {
    EXPECT_EQ(e.error_number(), ETIMEDOUT) << e.what();
  }
  // The daemon makes room after 100 ms: the client gets in and is served.
  std::thread daemon([&] {
    std::this_thread::sleep_for(100ms);
    std::vector<int> accepted;
    for (std::size_t i = 0; i <= queued.size(); ++i)
      accepted.push_back(::accept(listen_fd, nullptr, nullptr));
    char c = 0;
    while (::recv(accepted.back(), &c, 1, 0) == 1 && c != '\n') {
    }
    const std::string reply = R"({"jsonrpc":"2.0","id":1,"result":{"ok":true}})"
                              "\n";
    [[maybe_unused]] auto sent = ::send(accepted.back(), reply.data(), reply.size(), MSG_NOSIGNAL);
    for (const int fd : accepted) ::close(fd);
  });
  auto client = Client::connect(path, 5s);
  EXPECT_EQ(client.call("status"), json({{"ok", true}}));
  daemon.join();
  for (const int fd : queued) ::close(fd);
  ::close(listen_fd);
}

/// A daemon that answers the first request line with `reply`, whatever it was.
class FakeDaemon {
 public:
  FakeDaemon(const std::string& path, std::string reply) : reply_(std::move(reply)) {
    listen_fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    path.copy(addr.sun_path, sizeof(addr.sun_path) - 1);
    if (::bind(listen_fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 ||
        ::listen(listen_fd_, 1) != 0)
      throw std::runtime_error("fake daemon: bind/listen failed");
    thread_ = std::thread([this] {
      int fd = ::accept(listen_fd_, nullptr, nullptr);
      if (fd < 0) return;
      char c = 0;
      while (::recv(fd, &c, 1, 0) == 1 && c != '\n') {
      }
      std::size_t off = 0;
      while (off < reply_.size()) {
        ssize_t n = ::send(fd, reply_.data() + off, reply_.size() - off, MSG_NOSIGNAL);
        if (n <= 0) break;
        off += static_cast<std::size_t>(n);
      }
      ::shutdown(fd, SHUT_WR);
      while (::recv(fd, &c, 1, 0) == 1) {
      }
      ::close(fd);
    });
  }
  ~FakeDaemon() {
    thread_.join();
    ::close(listen_fd_);
  }
  FakeDaemon(const FakeDaemon&) = delete;
  FakeDaemon& operator=(const FakeDaemon&) = delete;

 private:
  std::string reply_;
  int listen_fd_ = -1;
  std::thread thread_;
};

// Issue 6: a reply nesting a million levels (a hostile or broken daemon) must
// not crash hapticctl: the client bounds nesting before parsing, as the server.
TEST(ClientReplies, NestingDeeperThanTheLimitIsAProtocolError) {
  hapticd::daemon::control::test::TempDir dir;
  const std::string path = dir.file("fake.sock");
  const std::size_t levels = 1'000'000;
  FakeDaemon daemon(path, R"({"jsonrpc":"2.0","id":1,"error":)" + std::string(levels, '[') +
                              std::string(levels, ']') + "}\n");
  auto c = Client::connect(path, 5s);
  try {
    c.call("status");
    FAIL() << "a million-level reply was accepted";
  } catch (const ProtocolError& e) {
    EXPECT_NE(std::string(e.what()).find("64 levels"), std::string::npos) << e.what();
  }
}

TEST(Assignment, ValuesBecomeTypedJson) {
  EXPECT_EQ(parse_value("2"), json(2));
  EXPECT_TRUE(parse_value("2").is_number_integer());
  EXPECT_EQ(parse_value("-3"), json(-3));
  EXPECT_EQ(parse_value("+4"), json(4));
  EXPECT_EQ(parse_value("2.5"), json(2.5));
  EXPECT_TRUE(parse_value("2.0").is_number_float());
  EXPECT_EQ(parse_value("1e3"), json(1000.0));
  EXPECT_EQ(parse_value("-.5"), json(-0.5));
  EXPECT_EQ(parse_value("5."), json(5.0));
  EXPECT_EQ(parse_value("true"), json(true));
  EXPECT_EQ(parse_value("false"), json(false));
  EXPECT_EQ(parse_value("null"), json(nullptr));
  // Names, not numbers.
  EXPECT_EQ(parse_value("forward-euler"), json("forward-euler"));
  EXPECT_EQ(parse_value("nan"), json("nan"));
  EXPECT_EQ(parse_value("inf"), json("inf"));
  EXPECT_EQ(parse_value("0x10"), json("0x10"));
  EXPECT_EQ(parse_value("1e999"), json("1e999"));
  EXPECT_EQ(parse_value("1e"), json("1e"));
  EXPECT_EQ(parse_value("."), json("."));
  EXPECT_EQ(parse_value("-"), json("-"));
  EXPECT_EQ(parse_value("3kg"), json("3kg"));
  EXPECT_EQ(parse_value("True"), json("True"));
  EXPECT_EQ(parse_value(""), json(""));
  // Quotes force a string.
  EXPECT_EQ(parse_value("\"2\""), json("2"));
  EXPECT_EQ(parse_value("'true'"), json("true"));
  // Integers too large for int64 stay numbers (as doubles).
  EXPECT_TRUE(parse_value("99999999999999999999").is_number_float());
}

TEST(Assignment, NameValuePairs) {
  auto [name, value] = parse_assignment("K=2000");
  EXPECT_EQ(name, "K");
  EXPECT_EQ(value, json(2000));
  EXPECT_EQ(parse_assignment("path=a=b").second, json("a=b"));
  EXPECT_EQ(parse_assignment("s=").second, json(""));
  EXPECT_THROW(parse_assignment("K"), AssignmentError);
  EXPECT_THROW(parse_assignment("=3"), AssignmentError);
  EXPECT_EQ(parse_assignments({"k=1", "integrator=rk4", "force=true"}),
            json({{"k", 1}, {"integrator", "rk4"}, {"force", true}}));
  EXPECT_EQ(parse_assignments({}), json::object());
  EXPECT_THROW(parse_assignments({"k=1", "k=2"}), AssignmentError);
  try {
    parse_assignment("oops");
  } catch (const AssignmentError& e) {
    EXPECT_NE(std::string(e.what()).find("name=value"), std::string::npos);
  }
}

}  // namespace

}  // namespace client_test
