// SIGTERM while the real hapticd configures its device (issue 17, item 9).
// The unit's TimeoutStopSec=5s SIGKILLs a daemon that does not exit; with
// connect_timeout = "20s" and a Modbus server that accepts and never
// answers, hapticd ran 13.2 s after SIGTERM. Each peer here accepts the
// connection, takes the first request and never answers it; the test sends
// SIGTERM once that request arrived and measures the time to exit. The
// design bound is 1 s (drivers::stop_slice is 100 ms); the assertion allows
// 3 s for this shared 2-vCPU machine, and the figure is printed.
#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "support.hpp"

namespace stop_during_configure_test {

namespace {

namespace fs = std::filesystem;
using namespace hapticd::e2e;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

/// hapticd on `config` (its [control] socket and [recorder] in `dir`),
/// stdout and stderr to dir/hapticd.log, not waited for: configure blocks.
class Configuring {
 public:
  Configuring(const TempDir& dir, const std::string& config) : log_(dir.path / "hapticd.log") {
    const fs::path file = dir.path / "hapticd.toml";
    std::ofstream(file) << config << "\n[control]\nsocket = \"" << (dir.path / "hapticd.sock").string()
                        << "\"\n[recorder]\ndirectory = \"" << dir.path.string() << "\"\n";
    const std::string binary = hapticd_binary().string(), path = file.string();
    pid_ = fork();
    if (pid_ == 0) {
      const int out = open(log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      dup2(out, 1);
      dup2(out, 2);
      execl(binary.c_str(), binary.c_str(), "--config", path.c_str(), static_cast<char*>(nullptr));
      _exit(127);
    }
  }
  ~Configuring() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  Configuring(const Configuring&) = delete;
  Configuring& operator=(const Configuring&) = delete;

  /// SIGTERM, then the exit status (or -1000 if it outlived `limit`); `seconds` from the signal to the exit.
  int terminate(double& seconds, std::chrono::seconds limit = 30s) {
    const auto sent = Clock::now();
    kill(pid_, SIGTERM);
    int status = 0;
    while (waitpid(pid_, &status, WNOHANG) != pid_) {
      if (Clock::now() - sent > limit) return -1000;
      std::this_thread::sleep_for(1ms);
    }
    seconds = std::chrono::duration<double>(Clock::now() - sent).count();
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
  }
  /// Not exited yet (the status is left for terminate()).
  bool running() const {
    siginfo_t info{};
    return pid_ > 0 && waitid(P_PID, static_cast<id_t>(pid_), &info, WEXITED | WNOHANG | WNOWAIT) == 0 &&
           info.si_pid == 0;
  }
  std::string log() const {
    std::ifstream in(log_);
    std::stringstream s;
    s << in.rdbuf();
    return s.str();
  }

 private:
  fs::path log_;
  pid_t pid_ = -1;
};

/// Waits up to 20 s for a connection on `listener`, then for `bytes` from it.
int accept_and_read(int listener, std::size_t bytes, std::vector<std::uint8_t>& got) {
  pollfd p{listener, POLLIN, 0};
  if (poll(&p, 1, 20000) <= 0) return -1;
  const int peer = accept(listener, nullptr, nullptr);
  std::array<std::uint8_t, 256> chunk{};
  while (peer >= 0 && got.size() < bytes) {
    pollfd q{peer, POLLIN, 0};
    if (poll(&q, 1, 20000) <= 0) break;
    const ssize_t n = read(peer, chunk.data(), chunk.size());
    if (n <= 0) break;
    got.insert(got.end(), chunk.begin(), chunk.begin() + n);
  }
  return peer;
}

const std::string scene =
    "[scene]\nname = \"spring-wheel\"\nstiffness = 0.5\ninertia = 0.0258\ndamping = \"auto\"\n"
    "integrator = \"exact\"\n";

}  // namespace

TEST(StopDuringConfigure, AModbusServerThatNeverAnswersDoesNotHoldSigterm) {
  const int listener = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof addr;
  ASSERT_EQ(bind(listener, reinterpret_cast<sockaddr*>(&addr), len), 0);
  ASSERT_EQ(listen(listener, 1), 0);
  ASSERT_EQ(getsockname(listener, reinterpret_cast<sockaddr*>(&addr), &len), 0);
  TempDir dir;
  Configuring hapticd(dir,
                      "[loop]\nperiod = \"5ms\"\n[device]\ndriver = \"modbus\"\ntorque_limit = 0.8\n"
                      "[device.modbus]\ntransport = \"tcp\"\nhost = \"127.0.0.1\"\nport = " +
                          std::to_string(ntohs(addr.sin_port)) +
                          "\nconnect_timeout = \"20s\"\nmass = 0.01\ndamping = 0.002\n" + scene);
  std::vector<std::uint8_t> request;
  const int peer = accept_and_read(listener, 12, request);  // MBAP 7 + fc 3 (5): the state read
  ASSERT_GE(peer, 0) << hapticd.log();
  ASSERT_EQ(request.size(), 12u) << hapticd.log();
  ASSERT_TRUE(hapticd.running()) << hapticd.log();
  double seconds = 0.0;
  EXPECT_EQ(hapticd.terminate(seconds), 0) << hapticd.log();
  std::printf("modbus (connect_timeout 20 s, a server that never answers): SIGTERM to exit %.3f s\n",
              seconds);
  EXPECT_LT(seconds, 3.0) << "the design bound is 1 s";
  EXPECT_NE(hapticd.log().find("hapticd: stopped by SIGTERM during configure"), std::string::npos)
      << hapticd.log();
  close(peer);
  close(listener);
}

// The SOCK_SEQPACKET seam of the canopen driver (interface = "unix:PATH"):
// each message one 16-byte struct can_frame. The peer takes the NMT command
// and the first SDO request (0x600 + node) and answers nothing.
TEST(StopDuringConfigure, ACanopenDriveThatNeverAnswersSdosDoesNotHoldSigterm) {
  TempDir dir;
  const std::string bus = (dir.path / "bus").string();
  const int listener = socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  ASSERT_LT(bus.size(), sizeof addr.sun_path);
  std::memcpy(addr.sun_path, bus.c_str(), bus.size() + 1);
  ASSERT_EQ(bind(listener, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  ASSERT_EQ(listen(listener, 1), 0);
  Configuring hapticd(
      dir,
      "[loop]\nperiod = \"5ms\"\n[device]\ndriver = \"canopen\"\ntorque_limit = 0.8\n"
      "[device.canopen]\ninterface = \"unix:" +
          bus + "\"\nnode_id = 5\nsdo_timeout = \"10s\"\ncounts_per_unit = 16384\nmass = 0.0258\n" + scene);
  pollfd p{listener, POLLIN, 0};
  ASSERT_GT(poll(&p, 1, 20000), 0) << hapticd.log();
  const int peer = accept(listener, nullptr, nullptr);
  ASSERT_GE(peer, 0);
  bool sdo = false;
  for (int i = 0; i < 16 && !sdo; ++i) {
    std::array<std::uint8_t, 16> frame{};  // can_id (host order), len, pad, data
    pollfd q{peer, POLLIN, 0};
    if (poll(&q, 1, 20000) <= 0 || read(peer, frame.data(), frame.size()) != 16) break;
    std::uint32_t id = 0;
    std::memcpy(&id, frame.data(), sizeof id);
    sdo = id == 0x605;
  }
  ASSERT_TRUE(sdo) << "no SDO request to node 5: " << hapticd.log();
  ASSERT_TRUE(hapticd.running()) << hapticd.log();
  double seconds = 0.0;
  EXPECT_EQ(hapticd.terminate(seconds), 0) << hapticd.log();
  std::printf("canopen (sdo_timeout 10 s, a drive that never answers): SIGTERM to exit %.3f s\n", seconds);
  EXPECT_LT(seconds, 3.0) << "the design bound is 1 s";
  EXPECT_NE(hapticd.log().find("hapticd: stopped by SIGTERM during configure"), std::string::npos)
      << hapticd.log();
  close(peer);
  close(listener);
}

}  // namespace stop_during_configure_test
