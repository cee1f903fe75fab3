// End-to-end safety of the real hapticd: injected device faults zero the
// output in the period they are seen and are reported; access control on the
// control socket; malformed requests cannot disturb the loop; SIGTERM stops
// cleanly with a complete recording.

#include <fcntl.h>
#include <grp.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "support.hpp"

namespace hapticd::e2e::safety_test {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using namespace std::chrono_literals;

constexpr unsigned flag_fault_latched = 1;
constexpr unsigned flag_read_error = 4;
constexpr unsigned flag_position_jump = 32;
constexpr double torque_limit = 2.0;  // N

// A linear 0.1 kg loopback with viscous damping, real clock, scene
// spring-mass (0.5 kg virtual mass on 79 N/m). Overruns never latch: the VM is
// noisy and an overrun fault would hide the fault under test.
const char* const spring_mass_device = R"(
[loop]
period = "1ms"
clock = "real"
overrun_limit = 0

[device]
driver = "loopback"
torque_limit = 2.0

[device.loopback]
motion = "linear"
mass = 0.1
damping = 1.0

[scene]
name = "spring-mass"
)";

unsigned flags_of(double v) { return static_cast<unsigned>(v); }

json status_json(const Daemon& d) {
  const auto r = d.ctl({"status", "--json"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return json::parse(r.out);
}

struct FaultRun {
  Recording rec;
  json status_during;     // status --json while the fault is active
  json stats_during;      // stats --json while the fault is active
  std::size_t first = 0;  // index of the first row flagged fault_latched or read_error
  bool found = false;
};

// Starts the daemon with the hand moving the device (an ideal hold on a 1 Hz
// sine, so the spring-mass output is a nonzero oscillation), records, injects
// the fault with `inject` (hapticctl args), waits, then clears it when `clear`.
FaultRun run_fault(const std::vector<std::string>& inject, bool clear) {
  FaultRun out;
  TempDir dir;
  Daemon d(dir, spring_mass_device);
  EXPECT_TRUE(d.running()) << d.log();
  const auto hand = d.ctl({"hand", "hold", "trajectory=sine", "amplitude=0.01", "frequency=1"});
  EXPECT_EQ(hand.exit_code, 0) << hand.err;
  std::this_thread::sleep_for(300ms);
  const auto start = d.ctl({"record", "start", "--path", "f.csv", "--json"});
  EXPECT_EQ(start.exit_code, 0) << start.err;
  const fs::path csv = json::parse(start.out).value("path", "");
  std::this_thread::sleep_for(150ms);
  const auto injected = d.ctl(inject);
  EXPECT_EQ(injected.exit_code, 0) << injected.err;
  std::this_thread::sleep_for(200ms);
  out.status_during = status_json(d);
  const auto stats = d.ctl({"stats", "--json"});
  EXPECT_EQ(stats.exit_code, 0) << stats.err;
  out.stats_during = json::parse(stats.out);
  if (clear) {
    const auto cleared = d.ctl({"fault", "clear"});
    EXPECT_EQ(cleared.exit_code, 0) << cleared.err;
    std::this_thread::sleep_for(200ms);
    EXPECT_TRUE(status_json(d)["fault"].is_null());
  }
  const auto stop = d.ctl({"record", "stop"});
  EXPECT_EQ(stop.exit_code, 0) << stop.err;
  EXPECT_EQ(d.stop(), 0) << d.log();
  out.rec = read_recording(csv);
  const auto flags = out.rec.values("flags");
  for (std::size_t i = 0; i < flags.size(); ++i) {
    if ((flags_of(flags[i]) & (flag_fault_latched | flag_read_error)) != 0) {
      out.first = i;
      out.found = true;
      break;
    }
  }
  return out;
}

double max_abs(const std::vector<double>& v, std::size_t begin, std::size_t end) {
  double m = 0.0;
  for (std::size_t i = begin; i < end && i < v.size(); ++i) m = std::max(m, std::abs(v[i]));
  return m;
}

// The first row without fault_latched after the latched stretch that starts
// at `first`, i.e. the first period after `fault clear`.
std::size_t first_after_clear(const Recording& rec, std::size_t first) {
  const auto flags = rec.values("flags");
  std::size_t i = first;
  while (i < flags.size() && (flags_of(flags[i]) & flag_fault_latched) != 0) ++i;
  return i;
}

// Checks for a fault that latches: zero in the first flagged period (or, for
// `one_late`, the period after: the write that failed was already computed),
// zero while latched, reported by status, and no step after the clear.
void expect_latched_fault(const FaultRun& r, const std::string& reason, bool one_late = false) {
  ASSERT_TRUE(r.found) << "no flagged row in the recording";
  const auto applied = r.rec.values("applied_n");
  const auto flags = r.rec.values("flags");
  ASSERT_GT(r.first, 10u) << "the fault must come after some normal periods";
  const std::size_t zero_from = one_late ? r.first + 1 : r.first;
  ASSERT_LT(zero_from, applied.size());
  EXPECT_EQ(applied[zero_from], 0.0) << "row " << zero_from;
  EXPECT_NE(applied[r.first - 1], 0.0)
      << "the output before the fault must be nonzero for this test to mean anything";
  const double before = max_abs(applied, 0, r.first);
  EXPECT_GT(before, 0.05);
  // Held at exactly zero while latched.
  const std::size_t resume = first_after_clear(r.rec, r.first);
  ASSERT_LT(resume, applied.size()) << "the fault was never cleared in the recording";
  EXPECT_GT(resume, r.first + 100) << "latched for ~0.2 s";
  for (std::size_t i = zero_from; i < resume; ++i) {
    ASSERT_EQ(applied[i], 0.0) << "row " << i << " while latched";
    ASSERT_NE(flags_of(flags[i]) & flag_fault_latched, 0u) << "row " << i;
  }
  // Status reported the fault while it was latched.
  EXPECT_EQ(r.status_during.value("state", ""), "fault") << r.status_during.dump();
  ASSERT_TRUE(r.status_during["fault"].is_string()) << r.status_during.dump();
  EXPECT_EQ(r.status_during["fault"].get<std::string>(), reason);
  // Faults the loop itself latches are counted (estop is latched by the control thread).
  if (reason != "estop") {
    EXPECT_GE(r.stats_during["faults_latched"].get<std::uint64_t>(), 1u);
  }
  // After the clear the scene restarts at equilibrium: no step (a spring
  // stretched for 0.2 s would jump straight to the torque limit), and the
  // output does resume.
  EXPECT_LT(std::abs(applied[resume]), 0.1 * before)
      << "first applied after clear " << applied[resume] << " vs " << before << " before";
  EXPECT_GT(max_abs(applied, resume, applied.size()), 0.0) << "output did not resume after the clear";
  for (double a : applied) ASSERT_LE(std::abs(a), torque_limit);
}

TEST(Safety, ReadErrorForOnePeriodZeroesThatPeriodOnly) {
  const FaultRun r = run_fault({"fault", "inject", "read-error", "amount=1"}, false);
  ASSERT_TRUE(r.found);
  const auto applied = r.rec.values("applied_n");
  const auto flags = r.rec.values("flags");
  ASSERT_GT(r.first, 10u);
  ASSERT_LT(r.first + 1, applied.size());
  EXPECT_EQ(applied[r.first], 0.0);
  EXPECT_NE(applied[r.first - 1], 0.0);
  EXPECT_NE(flags_of(flags[r.first]) & flag_read_error, 0u);
  EXPECT_EQ(flags_of(flags[r.first]) & flag_fault_latched, 0u) << "one read error is below the streak limit";
  // Exactly one period: the next one is normal again.
  EXPECT_EQ(flags_of(flags[r.first + 1]) & (flag_read_error | flag_fault_latched), 0u);
  EXPECT_NE(applied[r.first + 1], 0.0);
  std::size_t flagged = 0;
  for (double f : flags) flagged += (flags_of(f) & flag_read_error) != 0 ? 1 : 0;
  EXPECT_EQ(flagged, 1u);
  // Reported as a counted read error, not as a latched fault.
  EXPECT_TRUE(r.status_during["fault"].is_null()) << r.status_during.dump();
  EXPECT_EQ(r.stats_during["read_errors"].get<std::uint64_t>(), 1u) << r.stats_during.dump();
}

TEST(Safety, NanPositionLatchesAndZeroesInTheSamePeriod) {
  expect_latched_fault(run_fault({"fault", "inject", "nan"}, true), "non-finite position from the device");
}

TEST(Safety, DeviceFaultLatchesAndZeroesInTheSamePeriod) {
  expect_latched_fault(run_fault({"fault", "inject", "fault"}, true), "device fault");
}

TEST(Safety, EstopLatchesAndZeroes) {
  // estop is latched by the control thread at any point of a period: the
  // period that sees it first outputs zero, except when it lands between the
  // output computation and the flag, then the next one does.
  const FaultRun r = run_fault({"estop"}, true);
  ASSERT_TRUE(r.found);
  const auto applied = r.rec.values("applied_n");
  expect_latched_fault(r, "estop", /*one_late=*/applied[r.first] != 0.0);
}

TEST(Safety, StallLatchesWriteErrorAndZeroesFromTheNextPeriod) {
  // Stall: read() succeeds with a stale value, write() fails and the device
  // drops the command. The engine latches write_error in that period; the
  // recorded applied value of that one period is what it tried to send (the
  // device dropped it), and every later period is exactly zero.
  const FaultRun r = run_fault({"fault", "inject", "stall"}, true);
  ASSERT_TRUE(r.found);
  const auto applied = r.rec.values("applied_n");
  EXPECT_NE(applied[r.first], 0.0) << "the stalled period records the command the device dropped";
  expect_latched_fault(r, "write error", /*one_late=*/true);
  EXPECT_GE(r.stats_during["write_errors"].get<std::uint64_t>(), 1u);
}

// Issue 17: a position jump used to be taken as motion (no fault; the
// torque sat at the limit; the recording showed the jump without a flag).
// 2^31 counts of the 3.14 um encoder is 6.7 km in one period. The device's
// default max_velocity: 5 m/s for the hand + sqrt(2 x 2 N x 0.1 m / 0.1 kg)
// = 2 m/s for its motor = 7 m/s, so 7 mm + one count per period.
TEST(Safety, EncoderJumpLatchesAndZeroesInTheSamePeriod) {
  const FaultRun r = run_fault({"fault", "inject", "encoder-jump", "amount=2147483648"}, true);
  expect_latched_fault(r, "encoder jump / velocity limit");
  ASSERT_TRUE(r.found);
  const auto flags = r.rec.values("flags");
  const auto position = r.rec.values("position_m");
  const auto applied = r.rec.values("applied_n");
  EXPECT_NE(flags_of(flags[r.first]) & flag_position_jump, 0u) << "the jump's own sample is flagged";
  EXPECT_GT(std::abs(position[r.first] - position[r.first - 1]), 6000.0) << "the recording keeps the reading";
  for (std::size_t i = r.first; i < applied.size(); ++i)
    ASSERT_LT(std::abs(applied[i]), torque_limit) << "row " << i << ": at the torque limit after the jump";
  // The figures, in status while latched.
  const json& detail = r.status_during["fault_detail"];
  ASSERT_TRUE(detail.is_object()) << r.status_during.dump();
  EXPECT_EQ(detail["unit"], "m");
  // The jump plus the hand's motion over that period (a few counts).
  EXPECT_NEAR(detail["step_counts"].get<double>(), 2147483648.0, 100.0) << detail.dump();
  EXPECT_NEAR(detail["max_velocity"].get<double>(), 7.0, 1e-9);
  EXPECT_GE(detail["interval_s"].get<double>(), 1e-3);
  EXPECT_NEAR(detail["limit"].get<double>(), 7.0 * detail["interval_s"].get<double>() + 3.14e-6, 1e-9);
  const std::string text = detail["text"].get<std::string>();
  EXPECT_NE(text.find("encoder jump / velocity limit: the position stepped +"), std::string::npos) << text;
  EXPECT_NE(text.find("(+21474836"), std::string::npos) << text;
  EXPECT_NE(text.find("max_velocity 7 m/s"), std::string::npos) << text;
  EXPECT_EQ(r.stats_during["position_jumps"].get<std::uint64_t>(), 1u) << r.stats_during.dump();
}

// ---------------------------------------------------------------------------
// Access control.

struct AsUser {
  int exit_code = -1;
  std::string out, err;
};

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// A world-readable scratch directory holding a copy of hapticctl: nobody must
// be able to exec it even when the build tree sits under a 0700 directory
// (a clone in a mktemp -d, a home directory).
struct NobodyScratch {
  NobodyScratch() {
    fs::permissions(dir.path, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                  fs::perms::others_read | fs::perms::others_exec);
    fs::copy_file(hapticctl_binary(), program);
    fs::permissions(program, fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                 fs::perms::others_read | fs::perms::others_exec);
  }
  TempDir dir;
  fs::path program = dir.path / "hapticctl";
};

// Runs hapticctl (the scratch copy) as uid/gid 65534 (nobody) with no
// supplementary groups. Exit 127: nobody could not exec it.
AsUser hapticctl_as_nobody(const NobodyScratch& scratch, const std::vector<std::string>& args) {
  const fs::path out = scratch.dir.path / "nobody.out";
  const fs::path err = scratch.dir.path / "nobody.err";
  const pid_t pid = fork();
  if (pid == 0) {
    const int o = open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int e = open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int n = open("/dev/null", O_RDONLY);
    if (o < 0 || e < 0 || n < 0) _exit(120);
    dup2(n, 0);
    dup2(o, 1);
    dup2(e, 2);
    if (setgroups(0, nullptr) != 0 || setgid(65534) != 0 || setuid(65534) != 0) _exit(121);
    if (getuid() != 65534 || geteuid() != 65534) _exit(122);
    std::string program = scratch.program.string();
    std::vector<std::string> copy = args;
    std::vector<char*> argv{program.data()};
    for (auto& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv(program.c_str(), argv.data());
    _exit(127);
  }
  AsUser r;
  int status = 0;
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (waitpid(pid, &status, WNOHANG) != pid) {
    if (std::chrono::steady_clock::now() > deadline) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      return r;
    }
    std::this_thread::sleep_for(5ms);
  }
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

TEST(Safety, NonMemberPeerIsRefusedWrites) {
  if (geteuid() != 0) GTEST_SKIP() << "needs root to run a client as nobody";
  TempDir dir;
  Daemon d(dir, spring_mass_device);
  ASSERT_TRUE(d.running()) << d.log();
  const NobodyScratch scratch;  // nobody's hapticctl and captured output
  const std::string sock = d.socket().string();

  // As shipped, the socket is mode 0660 owned by the daemon (root, no control
  // group): nobody cannot even connect. That is unreachable, exit 3.
  struct stat st {};
  ASSERT_EQ(stat(sock.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0660u);
  chmod(dir.path.c_str(), 0755);  // the temp dir itself must not be what stops nobody
  const AsUser blocked = hapticctl_as_nobody(scratch, {"--socket", sock, "status"});
  EXPECT_EQ(blocked.exit_code, 3) << blocked.err;
  EXPECT_NE(blocked.err.find(sock), std::string::npos) << blocked.err;

  // Opened to everyone (0666): reads work, writes are refused per SO_PEERCRED.
  ASSERT_EQ(chmod(sock.c_str(), 0666), 0);
  const AsUser status = hapticctl_as_nobody(scratch, {"--socket", sock, "status"});
  EXPECT_EQ(status.exit_code, 0) << status.err;
  EXPECT_NE(status.out.find("spring-mass"), std::string::npos) << status.out;

  const AsUser set = hapticctl_as_nobody(scratch, {"--socket", sock, "set", "stiffness=1"});
  EXPECT_EQ(set.exit_code, 1) << set.out << set.err;
  EXPECT_NE(set.err.find("not permitted"), std::string::npos) << set.err;
  EXPECT_NE(set.err.find("65534"), std::string::npos) << set.err;

  for (const std::vector<std::string>& verb : std::vector<std::vector<std::string>>{
           {"load", "free"}, {"fault", "inject", "nan"}, {"record", "start"}, {"hand", "free"}}) {
    std::vector<std::string> args{"--socket", sock};
    args.insert(args.end(), verb.begin(), verb.end());
    const AsUser r = hapticctl_as_nobody(scratch, args);
    EXPECT_EQ(r.exit_code, 1) << verb.front() << ": " << r.err;
    EXPECT_NE(r.err.find("not permitted"), std::string::npos) << verb.front() << ": " << r.err;
  }
  // Nothing changed: same scene, no fault, not recording, stiffness as configured.
  const json after = status_json(d);
  EXPECT_EQ(after["scene"]["name"], json("spring-mass"));
  EXPECT_TRUE(after["fault"].is_null());
  EXPECT_FALSE(after["recording"]["active"].get<bool>());
  EXPECT_NEAR(after["scene"]["parameters"]["stiffness"].get<double>(), 78.95683521, 1e-6);

  // estop is read access by design (docs/protocol.md): anyone who can connect
  // may stop the device; only writers can clear it.
  const AsUser estop = hapticctl_as_nobody(scratch, {"--socket", sock, "estop"});
  EXPECT_EQ(estop.exit_code, 0) << estop.err;
  EXPECT_EQ(status_json(d)["fault"], json("estop"));
  const AsUser clear = hapticctl_as_nobody(scratch, {"--socket", sock, "fault", "clear"});
  EXPECT_EQ(clear.exit_code, 1) << clear.err;
  EXPECT_EQ(status_json(d)["fault"], json("estop"));
  EXPECT_EQ(d.ctl({"fault", "clear"}).exit_code, 0);
  EXPECT_TRUE(status_json(d)["fault"].is_null());
  EXPECT_EQ(d.stop(), 0) << d.log();
}

// ---------------------------------------------------------------------------
// Malformed requests.

int connect_unix(const fs::path& path) {
  const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return -1;
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  const std::string text = path.string();
  if (text.size() >= sizeof addr.sun_path) {
    close(fd);
    return -1;
  }
  std::memcpy(addr.sun_path, text.c_str(), text.size() + 1);
  if (connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

bool send_all(int fd, const std::string& data) {
  std::size_t sent = 0;
  while (sent < data.size()) {
    const ssize_t n = send(fd, data.data() + sent, data.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) return false;
    sent += static_cast<std::size_t>(n);
  }
  return true;
}

// One '\n'-terminated line, or "" on timeout / EOF.
std::string read_line(int fd, std::string& buffer, std::chrono::milliseconds timeout = 5000ms) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    const auto nl = buffer.find('\n');
    if (nl != std::string::npos) {
      std::string line = buffer.substr(0, nl);
      buffer.erase(0, nl + 1);
      return line;
    }
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return "";
    pollfd p{fd, POLLIN, 0};
    if (poll(&p, 1, static_cast<int>(left.count())) <= 0) return "";
    char chunk[4096];
    const ssize_t n = recv(fd, chunk, sizeof chunk, 0);
    if (n <= 0) return "";
    buffer.append(chunk, static_cast<std::size_t>(n));
  }
}

std::vector<std::string> malformed_requests() {
  std::vector<std::string> base{
      "garbage",
      "{",
      "}",
      "[]",
      "[1,2,3]",
      "null",
      "42",
      "\"just a string\"",
      "{\"jsonrpc\":\"1.0\",\"id\":1,\"method\":\"status\"}",
      "{\"jsonrpc\":\"2.0\",\"id\":1}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":7}",
      "{\"jsonrpc\":\"2.0\",\"id\":{\"a\":1},\"method\":\"status\"}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"no.such.method\"}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"param.set\",\"params\":[1,2]}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"param.set\",\"params\":{\"params\":{\"stiffness\":1e308}}}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"param.set\",\"params\":{\"params\":{\"stiffness\":-1}}}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"param.set\",\"params\":{\"params\":{\"stiffness\":\"soft\"}"
      "}}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"param.set\",\"params\":{\"params\":{\"bogus\":1}}}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"param.set\",\"params\":{\"params\":{}}}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"param.set\",\"params\":{\"params\":{\"mass\":0},\"force\":"
      "\"yes\"}}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"scene.load\",\"params\":{\"scene\":5}}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"scene.load\",\"params\":{\"scene\":\"no-such-scene\"}}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"scene.load\",\"params\":{\"scene\":\"wall\",\"params\":{"
      "\"stiffness\":"
      "123456789012345678901234567890}}}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"param.get\",\"params\":{\"names\":\"stiffness\"}}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"param.get\",\"params\":{\"names\":[1,2]}}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"hand.set\",\"params\":{\"mode\":\"juggle\"}}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"hand.set\",\"params\":{\"text\":17}}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"fault.inject\",\"params\":{\"kind\":\"meteor\"}}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"fault.inject\",\"params\":{\"kind\":\"nan\",\"amount\":"
      "\"x\"}}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"fault.inject\",\"params\":{\"kind\":\"nan\",\"amount\":1.5}"
      "}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"stream\",\"params\":{\"rate_hz\":1e300}}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"stream\",\"params\":{\"rate_hz\":\"fast\"}}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"stream\",\"params\":{\"rate_hz\":10,\"channels\":[\"nope\"]"
      "}}",
      "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"record.start\",\"params\":{\"path\":\"../escape.csv\"}}",
      std::string("{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"status\",\"x\":\"\xff\xfe\"}"),
      "{\"jsonrpc\":\"2.0\",\"id\":99999999999999999999999999,\"method\":\"nope\"}",
  };
  std::vector<std::string> out;
  out.reserve(1000);
  while (out.size() < 1000) out.push_back(base[out.size() % base.size()]);
  return out;
}

// Rows are not parsed (the virtual clock writes ~10^6 per second): only the
// comment lines and the number of data lines.
struct Trailer {
  std::vector<std::string> comments;
  std::size_t data_lines = 0;
  std::string last_line;
};
Trailer scan_recording(const fs::path& csv) {
  Trailer t;
  std::ifstream in(csv);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    t.last_line = line;
    if (line[0] == '#') {
      t.comments.push_back(line);
    } else if (line.rfind("time_s,", 0) != 0) {
      ++t.data_lines;
    }
  }
  return t;
}

bool has_line(const Trailer& t, const std::string& text) {
  for (const auto& c : t.comments) {
    if (c == text) return true;
  }
  return false;
}

TEST(Safety, MalformedRequestsDoNotDisturbTheLoop) {
  // Virtual clock: no overrun can come from the host, so any overrun or lost
  // sample would be the control plane's doing. The duration only has to
  // outlast the test (the virtual loop runs ~10^6 periods per wall second).
  TempDir dir;
  Daemon d(dir, R"(
[loop]
period = "1ms"
clock = "virtual"
duration = "100000s"

[device]
driver = "loopback"
torque_limit = 2.0

[device.loopback]
motion = "linear"
mass = 0.1
damping = 1.0

[scene]
name = "spring-mass"
)",
           {"--record", "malformed.csv"});
  ASSERT_TRUE(d.running()) << d.log();
  ASSERT_EQ(d.ctl({"hand", "hold", "trajectory=sine", "amplitude=0.01", "frequency=1"}).exit_code, 0);
  const auto before = d.ctl({"stats", "--json"});
  ASSERT_EQ(before.exit_code, 0) << before.err;
  const json stats_before = json::parse(before.out);
  EXPECT_EQ(stats_before["overruns"].get<std::uint64_t>(), 0u);

  const int fd = connect_unix(d.socket());
  ASSERT_GE(fd, 0);
  std::string buffer;
  std::size_t errors = 0;
  const auto requests = malformed_requests();
  ASSERT_EQ(requests.size(), 1000u);
  for (const auto& request : requests) {
    ASSERT_TRUE(send_all(fd, request + "\n"));
    const std::string reply = read_line(fd, buffer);
    ASSERT_FALSE(reply.empty()) << "no reply to " << request;
    const json parsed = json::parse(reply, nullptr, false);
    ASSERT_FALSE(parsed.is_discarded()) << reply;
    EXPECT_TRUE(parsed.contains("error")) << request << " -> " << reply;
    errors += parsed.contains("error") ? 1 : 0;
  }
  close(fd);
  EXPECT_EQ(errors, 1000u);

  // An oversized line on its own connection: -32003, then closed.
  const int big = connect_unix(d.socket());
  ASSERT_GE(big, 0);
  const std::string huge = "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"status\",\"pad\":\"" +
                           std::string(200 * 1024, 'x') + "\"}\n";
  send_all(big, huge);  // the server may close before it has read it all
  std::string big_buffer;
  const std::string too_large = read_line(big, big_buffer);
  EXPECT_NE(too_large.find("-32003"), std::string::npos) << too_large;
  close(big);

  const auto after = d.ctl({"stats", "--json"});
  ASSERT_EQ(after.exit_code, 0) << after.err;
  const json stats_after = json::parse(after.out);
  EXPECT_EQ(stats_after["overruns"].get<std::uint64_t>(), 0u);
  EXPECT_EQ(stats_after["missed_periods"].get<std::uint64_t>(), 0u);
  EXPECT_GT(stats_after["cycles"].get<std::uint64_t>(), stats_before["cycles"].get<std::uint64_t>());
  EXPECT_GE(stats_after["control"]["errors"].get<std::uint64_t>(), 1000u) << stats_after["control"].dump();
  // The daemon's state is untouched.
  const json status = status_json(d);
  EXPECT_EQ(status["scene"]["name"], json("spring-mass"));
  EXPECT_TRUE(status["fault"].is_null());
  EXPECT_NEAR(status["scene"]["parameters"]["stiffness"].get<double>(), 78.95683521, 1e-6);

  ASSERT_TRUE(d.running()) << "the loop ended before the test: raise the duration\n" << d.log();
  // The recording is stopped while the loop runs. (Stopping the daemon with
  // the recording still open can lose the one sample the virtual-clock loop
  // was waiting to push when the stop came: it is counted, "ring full: 1",
  // never silent; that is the engine's shutdown, not the control plane.)
  const auto rec_stop = d.ctl({"record", "stop", "--json"});
  ASSERT_EQ(rec_stop.exit_code, 0) << rec_stop.err;
  const json stopped = json::parse(rec_stop.out);
  EXPECT_EQ(stopped["dropped_ring"].get<std::uint64_t>(), 0u) << rec_stop.out;
  EXPECT_EQ(stopped["dropped_write"].get<std::uint64_t>(), 0u) << rec_stop.out;
  EXPECT_EQ(stopped["cycle_gaps"].get<std::uint64_t>(), 0u) << rec_stop.out;
  EXPECT_EQ(d.stop(), 0) << d.log();
  const Trailer t = scan_recording(dir.path / "malformed.csv");
  EXPECT_TRUE(has_line(t, "# cycle_gaps: 0")) << t.last_line;
  EXPECT_TRUE(has_line(t, "# dropped 0 samples (ring full: 0, write failed: 0)")) << t.last_line;
  EXPECT_TRUE(has_line(t, "# samples_written: " + std::to_string(t.data_lines)));
  EXPECT_GT(t.data_lines, stats_before["cycles"].get<std::uint64_t>());
}

// KNOWN BUG (disabled): a number nlohmann cannot represent (1e999) throws
// json::out_of_range, not json::parse_error, and ControlServer only catches
// the latter around json::parse (daemon/control/server.cpp), so the client is
// dropped ("client N dropped: ... number overflow") instead of getting the
// -32700 reply docs/protocol.md promises. The loop is not affected. Run with
// --gtest_also_run_disabled_tests once server.cpp catches json::exception there.
TEST(Safety, NumberOverflowGetsAParseErrorReply) {
  TempDir dir;
  Daemon d(dir, spring_mass_device);
  ASSERT_TRUE(d.running()) << d.log();
  const int fd = connect_unix(d.socket());
  ASSERT_GE(fd, 0);
  std::string buffer;
  ASSERT_TRUE(send_all(fd,
                       "{\"jsonrpc\":\"2.0\",\"id\":1,\"method\":\"param.set\",\"params\":{\"params\":{"
                       "\"stiffness\":1e999}}}\n"));
  const std::string reply = read_line(fd, buffer);
  EXPECT_NE(reply.find("-32700"), std::string::npos) << "reply: '" << reply << "'\n" << d.log();
  close(fd);
  EXPECT_EQ(d.stop(), 0);
}

// ---------------------------------------------------------------------------
// SIGTERM.

TEST(Safety, SigtermExitsZeroWithACompleteRecordingAndTheDeviceStopped) {
  TempDir dir;
  Daemon d(dir, spring_mass_device, {"--record", "term.csv"});
  ASSERT_TRUE(d.running()) << d.log();
  ASSERT_EQ(d.ctl({"hand", "hold", "trajectory=sine", "amplitude=0.01", "frequency=1"}).exit_code, 0);
  std::this_thread::sleep_for(300ms);
  EXPECT_EQ(d.stop(), 0) << d.log();
  EXPECT_FALSE(d.running());

  const fs::path csv = dir.path / "term.csv";
  std::ifstream in(csv);
  std::string line, last;
  while (std::getline(in, line)) {
    if (!line.empty()) last = line;
  }
  EXPECT_EQ(last.rfind("# dropped ", 0), 0u) << "last line: " << last;
  const Recording rec = read_recording(csv);
  EXPECT_EQ(rec.header.at("cycle_gaps"), "0");
  EXPECT_EQ(last, "# dropped 0 samples (ring full: 0, write failed: 0)");
  ASSERT_GT(rec.rows.size(), 100u);
  EXPECT_EQ(rec.header.at("samples_written"), std::to_string(rec.rows.size()));
  const auto cycles = rec.values("cycle");
  for (std::size_t i = 1; i < cycles.size(); ++i) ASSERT_EQ(cycles[i], cycles[i - 1] + 1) << "row " << i;
  for (double a : rec.values("applied_n")) ASSERT_LE(std::abs(a), torque_limit);
  EXPECT_GT(max_abs(rec.values("applied_n"), 0, rec.rows.size()), 0.0);
  EXPECT_NE(d.log().find("SIGTERM: stopping"), std::string::npos) << d.log();

  // Stopped: the socket is gone and nobody answers.
  EXPECT_FALSE(fs::exists(d.socket()));
  const auto status = d.ctl({"status"});
  EXPECT_EQ(status.exit_code, 3) << status.out << status.err;
}

}  // namespace
}  // namespace hapticd::e2e::safety_test
