// The real hapticd binary against the simulated amplifier as its own
// process (`hapticd-devsim modbus`, commands on its stdin), over TCP on
// 127.0.0.1 and over RTU on a pseudo-terminal pair (issue 10, "Evidence"):
//  - the 45-degree step held on spring-wheel gives the torque of the
//    loopback run of the same plant with the amplifier's one period of delay
//    (within 1 % of the peak);
//  - an exception and a timeout streak each zero the output in the period
//    they are seen and latch with the amplifier's reason; `fault clear`
//    resumes without a torque step;
//  - a killed amplifier zeroes the output and latches (TCP: `fault clear`
//    reconnects to the amplifier when it is back);
//  - a killed hapticd lets the amplifier's watchdog disable the power stage.

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "support.hpp"

namespace modbus_e2e_test {

namespace {

using namespace hapticd::e2e;
using namespace std::chrono_literals;
using json = nlohmann::json;

constexpr unsigned flag_fault_latched = 1;
enum class Transport { tcp, rtu };
std::string name_of(Transport t) { return t == Transport::tcp ? "tcp" : "rtu"; }

// Periods with 90 % of the period for the exchange: this VM, shared by
// parallel builds, holds loopback TCP replies up to 1 ms and pty bytes (moved
// by a kernel worker at normal priority) for several ms, now and then over
// 50 ms: RTU runs at the longest period hapticd takes.
double period_of(Transport t) { return t == Transport::tcp ? 0.005 : 0.010; }
// Whole-VM stalls of 50 ms happen there too (the amplifier's watchdog saw
// them while hapticd's transactions all succeeded), and over the pty three
// 9 ms timeouts in a row.
int watchdog_ms(Transport) { return 200; }
int failure_streak(Transport t) { return t == Transport::tcp ? 5 : 10; }
// The step comes at 1.5 s of the amplifier's plant time: configure's 200
// round-trip samples over TCP step that plant 200 periods (1 s) before the
// loop starts.
const char* const step_hand = "mode=hold trajectory=step amplitude=0.785398163397448 at=1.5";
// The hand moves the wheel all the time (1 Hz, 0.3 rad), whenever the loop
// starts (configure's exchanges step the amplifier's plant a varying number
// of periods before): a torque at almost every moment.
const char* const swing_hand = "mode=hold trajectory=sine amplitude=0.3 frequency=1";
// Finer than the shipped 1 mN m so the loopback comparison is not about rounding.
const char* const torque_scale = "torque_per_count=0.0001";

/// `hapticd-devsim modbus` as a child process: its stdin and stdout are ours.
class AmplifierProcess {
 public:
  AmplifierProcess(Transport transport, const std::string& hand, int port = 0) {
    std::vector<std::string> args{
        (std::filesystem::path(HAPTICD_BINARY_DIR) / "sim" / "devsim" / "hapticd-devsim").string(),
        "modbus",
        "--transport",
        name_of(transport),
        "--port",
        std::to_string(port),
        "--period",
        std::to_string(period_of(transport)),
        "--hand",
        hand,
        "--torque-per-count",
        "0.0001",  // torque_scale's, in the amplifier's own settings
        "--priority",
        "70"};
    std::vector<char*> argv;
    argv.reserve(args.size() + 1);
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    int in[2], out[2];
    if (pipe2(in, O_CLOEXEC) != 0 || pipe2(out, O_CLOEXEC) != 0) throw std::runtime_error("pipe");
    pid_ = fork();
    if (pid_ < 0) throw std::runtime_error("fork");
    if (pid_ == 0) {
      dup2(in[0], 0);
      dup2(out[1], 1);
      execv(argv[0], argv.data());
      _exit(127);
    }
    close(in[0]);
    close(out[1]);
    to_ = in[1];
    from_ = out[0];
    banner_ = line(10s);
    // "modbus amplifier: tcp 127.0.0.1:PORT unit 1" or "... rtu /dev/pts/N slave 1"
    char where[256] = {};
    if (std::sscanf(banner_.c_str(), "modbus amplifier: tcp 127.0.0.1:%d", &port_) == 1) return;
    if (std::sscanf(banner_.c_str(), "modbus amplifier: rtu %255s", where) == 1) {
      pty_ = where;
      return;
    }
    throw std::runtime_error("hapticd-devsim modbus said: \"" + banner_ + "\"");
  }
  ~AmplifierProcess() { kill_now(); }
  AmplifierProcess(const AmplifierProcess&) = delete;
  AmplifierProcess& operator=(const AmplifierProcess&) = delete;

  /// One command on its stdin, its one-line answer.
  std::string command(const std::string& text) {
    const std::string l = text + "\n";
    if (::write(to_, l.data(), l.size()) != static_cast<ssize_t>(l.size())) return "";
    return line(5s);
  }
  json state() {
    const std::string answer = command("state");
    if (answer.rfind("ok ", 0) != 0) throw std::runtime_error("state: \"" + answer + "\"");
    return json::parse(answer.substr(3));
  }
  void kill_now() {
    if (pid_ <= 0) return;
    ::kill(pid_, SIGKILL);
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
    close(to_);
    close(from_);
  }
  int port() const { return port_; }
  const std::string& pty() const { return pty_; }

 private:
  std::string line(std::chrono::milliseconds limit) {
    const auto give_up = std::chrono::steady_clock::now() + limit;
    for (;;) {
      if (const auto eol = buffer_.find('\n'); eol != std::string::npos) {
        std::string l = buffer_.substr(0, eol);
        buffer_.erase(0, eol + 1);
        return l;
      }
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(give_up - std::chrono::steady_clock::now());
      pollfd p{from_, POLLIN, 0};
      if (left.count() <= 0 || poll(&p, 1, static_cast<int>(left.count())) <= 0) return "";
      char chunk[512];
      const ssize_t n = ::read(from_, chunk, sizeof chunk);
      if (n <= 0) return "";
      buffer_.append(chunk, static_cast<std::size_t>(n));
    }
  }

  pid_t pid_ = -1;
  int to_ = -1, from_ = -1;
  std::string buffer_, banner_, pty_;
  int port_ = 0;
};

// The scene of config/modbus.toml: the gate accepts it with one period of delay.
const std::string scene =
    "[scene]\nname = \"spring-wheel\"\nstiffness = 0.5\ninertia = 0.0258\ndamping = \"auto\"\n"
    "integrator = \"exact\"\n";

std::string modbus_device(const AmplifierProcess& a, Transport t) {
  std::string link =
      t == Transport::tcp
          ? "transport = \"tcp\"\nhost = \"127.0.0.1\"\nport = " + std::to_string(a.port()) + "\n"
          // A pty does not emulate the line rate: 4 Mbaud with 3.5-character silences
          // is a computed cycle (0.11 ms) well inside the period.
          : "transport = \"rtu\"\ndevice = \"" + a.pty() + "\"\nbaud = 4000000\nsilence = \"characters\"\n";
  return "[device]\ndriver = \"modbus\"\ntorque_limit = 0.8\n[device.modbus]\n" + link + torque_scale +
         "\nmass = 0.01\ndamping = 0.002\nlink_budget = 0.9\nwatchdog_value = " +
         std::to_string(watchdog_ms(t)) + "\nfailure_streak = " + std::to_string(failure_streak(t)) + "\n";
}

std::string loop(Transport t, const std::string& keys) {
  return "[loop]\nperiod = \"" + std::to_string(std::lround(period_of(t) * 1e3)) + "ms\"\n" + keys + "\n";
}

/// hapticd on the real clock against `a`. A host too loaded to carry the
/// period (CI's sanitizer stage saw 3 of 200 exchanges late at 5 ms) is
/// refused at configure with its figure, as it must be; such a start is
/// tried again, at most twice, and said so. The last start is judged
/// whatever it shows.
std::unique_ptr<Daemon> start_on_the_real_clock(const TempDir& dir, const AmplifierProcess& a, Transport t,
                                                const std::string& device_keys = "") {
  const std::string config =
      modbus_device(a, t) + device_keys + loop(t, "clock = \"real\"\noverrun_limit = 0") + scene;
  for (int attempt = 1;; ++attempt) {
    auto d = std::make_unique<Daemon>(dir, config);
    const std::string log = d->running() ? std::string() : d->log();
    if (log.find("periodic exchanges at configure") == std::string::npos || attempt == 3) return d;
    std::printf("modbus: hapticd refused the link on this host (start %d): %s; again\n", attempt,
                log.c_str());
  }
}

json status_of(const Daemon& d) {
  const auto r = d.ctl({"status", "--json"});
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return r.exit_code == 0 ? json::parse(r.out) : json{};
}

template <class Done>
bool within(std::chrono::milliseconds limit, Done done) {
  const auto give_up = std::chrono::steady_clock::now() + limit;
  while (!done()) {
    if (std::chrono::steady_clock::now() > give_up) return false;
    std::this_thread::sleep_for(10ms);
  }
  return true;
}

std::size_t first_moving_row(const std::vector<double>& position) {
  for (std::size_t i = 0; i < position.size(); ++i)
    if (position[i] != 0.0) return i;
  return position.size();
}

// The scripted hand's ideal 45-degree step moves the device 0.785 rad in
// one period (785 rad/s at 1 ms), faster than the default max_velocity lets
// a device move (docs/config.md, "Position plausibility"): runs with it
// allow that speed.
std::string allowing_ideal_steps(std::string config) {
  const std::string device = "[device]\n";
  const auto at = config.find(device);
  if (at != std::string::npos) config.insert(at + device.size(), "max_velocity = 1000\n");
  return config;
}

class ModbusEndToEnd : public ::testing::TestWithParam<Transport> {};

TEST_P(ModbusEndToEnd, SpringWheelStepMatchesTheLoopbackRun) {
  const std::string virtual_run = loop(GetParam(), "clock = \"virtual\"\nduration = \"5s\"");
  TempDir loopback_dir;
  {
    Daemon d(
        loopback_dir,
        allowing_ideal_steps(
            "[device]\ndriver = \"loopback\"\ntorque_limit = 0.8\n[device.loopback]\nmotion = \"rotary\"\n"
            "delay = 1\nhand = \"" +
            std::string(step_hand) + "\"\n" + virtual_run + scene),
        {"--record", "run.csv"});
    ASSERT_EQ(d.wait(std::chrono::seconds(300)), 0) << d.log();
  }
  // A run in which the host failed a transaction (a flagged row: a read
  // error, a latch; or configure refusing the link it measured) is not the
  // comparison asked for: up to three runs, each with a new amplifier, until
  // one has every transaction answered; that one is compared.
  std::unique_ptr<AmplifierProcess> amplifier;
  std::unique_ptr<TempDir> modbus_dir;
  std::size_t flagged = 0;
  int runs = 0;
  for (; runs < 3; ++runs) {
    amplifier = std::make_unique<AmplifierProcess>(GetParam(), step_hand);
    modbus_dir = std::make_unique<TempDir>();
    Daemon d(*modbus_dir, allowing_ideal_steps(modbus_device(*amplifier, GetParam()) + virtual_run + scene),
             {"--record", "run.csv"});
    const int status = d.wait(std::chrono::seconds(300));
    flagged = 0;
    if (status == 0) {
      for (const double f : read_recording(modbus_dir->path / "run.csv").values("flags")) flagged += f != 0.0;
      if (flagged == 0) break;
    } else {
      const std::string log = d.log();
      ASSERT_NE(log.find("exchanges"), std::string::npos)
          << "refused for another reason than the link: " << log;
    }
    std::printf("modbus %s run %d: a transaction failed on this host (%zu rows flagged, status %d): again\n",
                name_of(GetParam()).c_str(), runs + 1, flagged, status);
  }
  ASSERT_LT(runs, 3) << "no run of three had every transaction answered";
  const Recording loopback = read_recording(loopback_dir.path / "run.csv");
  const Recording modbus = read_recording(modbus_dir->path / "run.csv");

  // configure() measures the link with real transactions, each a plant step
  // at rest: the amplifier's plant clock runs ahead of the loop's by those.
  // Both systems are at rest until the hand's step, so the runs are compared
  // from the first period the wheel moves.
  const auto expected = loopback.values("applied_n_m");
  const auto got = modbus.values("applied_n_m");
  const std::size_t a = first_moving_row(loopback.values("position_rad"));
  const std::size_t b = first_moving_row(modbus.values("position_rad"));
  ASSERT_EQ(a, static_cast<std::size_t>(std::lround(1.5 / period_of(GetParam()))))
      << "the loopback's hand steps at 1.5 s";
  ASSERT_LT(b, a) << "the amplifier's plant stepped at configure";
  const std::size_t n = std::min(expected.size() - a, got.size() - b);
  ASSERT_GE(n, static_cast<std::size_t>(std::lround(3.5 / period_of(GetParam()))));
  double peak = 0.0, worst = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    peak = std::max(peak, std::abs(expected[a + i]));
    worst = std::max(worst, std::abs(got[b + i] - expected[a + i]));
  }
  for (std::size_t i = 0; i < b; ++i) ASSERT_EQ(got[i], 0.0) << "row " << i << " before the step";
  // k z0, and in the step's period the damping (auto: b = T k) on the step's velocity as much again.
  EXPECT_NEAR(peak, 2 * 0.5 * 0.785398, 0.01) << "k z0 + b z0 / T";
  EXPECT_LE(worst, 0.01 * peak) << "largest torque difference " << worst << " N m, peak " << peak;
  std::printf(
      "modbus %s vs loopback (delay 1): %zu samples from the step, peak %.6f N m, largest difference "
      "%.3g N m (%.3g %% of peak); amplifier plant %zu steps ahead\n",
      name_of(GetParam()).c_str(), n, peak, worst, 100.0 * worst / peak, a - b);
  const json s = amplifier->state();
  EXPECT_FALSE(s["watchdog_armed"].get<bool>()) << "a clean exit disarms the watchdog: " << s.dump();
  EXPECT_EQ(s["torque_counts"], 0) << s.dump();
  EXPECT_EQ(s["watchdog_trips"], 0) << s.dump();
}

/// The recording's fault episodes: [first latched row, first row after).
std::vector<std::pair<std::size_t, std::size_t>> episodes(const Recording& rec) {
  const auto flags = rec.values("flags");
  std::vector<std::pair<std::size_t, std::size_t>> out;
  for (std::size_t i = 0; i < flags.size(); ++i) {
    if ((static_cast<unsigned>(flags[i]) & flag_fault_latched) == 0) continue;
    std::size_t end = i;
    while (end < flags.size() && (static_cast<unsigned>(flags[end]) & flag_fault_latched) != 0) ++end;
    out.emplace_back(i, end);
    i = end;
  }
  return out;
}

// Injects a failure, waits for the latch with `reason`, checks the amplifier
// holds no torque, clears.
void fault_and_clear(const Daemon& d, AmplifierProcess& amplifier, const std::string& injection,
                     const std::string& reason) {
  ASSERT_EQ(amplifier.command(injection), "ok");
  ASSERT_TRUE(within(3000ms, [&] { return status_of(d).value("state", "") == "fault"; }))
      << d.log() << status_of(d).dump() << "\namplifier: " << amplifier.state().dump();
  const json during = status_of(d);
  EXPECT_EQ(during["device"]["fault_reason"], reason) << during.dump();
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(amplifier.state()["torque_counts"], 0) << "latched: torque 0 at the amplifier";
  const auto cleared = d.ctl({"fault", "clear", "--json"});
  ASSERT_EQ(cleared.exit_code, 0) << cleared.err << cleared.out << d.log();
  EXPECT_NE(cleared.out.find(reason), std::string::npos) << cleared.out;
  ASSERT_TRUE(within(3000ms, [&] { return status_of(d).value("state", "") == "running"; })) << d.log();
  std::this_thread::sleep_for(300ms);
}

TEST_P(ModbusEndToEnd, AnExceptionAndATimeoutStreakZeroTheOutputAndFaultClearResumes) {
  AmplifierProcess amplifier(GetParam(), swing_hand);
  TempDir dir;
  const auto started = start_on_the_real_clock(dir, amplifier, GetParam());
  Daemon& d = *started;
  ASSERT_TRUE(d.running()) << d.log();
  const auto start = d.ctl({"record", "start", "--path", "m.csv", "--json"});
  ASSERT_EQ(start.exit_code, 0) << start.err;
  const std::string csv = json::parse(start.out).value("path", "");
  std::this_thread::sleep_for(1000ms);
  ASSERT_EQ(status_of(d).value("state", ""), "running") << status_of(d).dump() << d.log();

  fault_and_clear(d, amplifier, "exception 4",
                  "exception 0x04 (server device failure) in reply to function 0x17");
  const std::string streak = std::to_string(failure_streak(GetParam()));
  fault_and_clear(d, amplifier, "timeout " + streak,
                  streak +
                      " failed transactions in a row, the last: no response within the response timeout to "
                      "function 0x17");
  ASSERT_EQ(d.ctl({"record", "stop"}).exit_code, 0);
  EXPECT_EQ(d.stop(), 0) << d.log();
  // SIGTERM: every exchange after the stop has one slice (100 ms), enough
  // for a live amplifier: torque 0, power stage off, watchdog disarmed.
  const json after = amplifier.state();
  EXPECT_FALSE(after["enabled"].get<bool>()) << after.dump();
  EXPECT_EQ(after["torque_counts"], 0) << after.dump();
  EXPECT_FALSE(after["watchdog_armed"].get<bool>()) << after.dump();

  const Recording rec = read_recording(csv);
  const auto applied = rec.values("applied_n_m");
  const auto found = episodes(rec);
  ASSERT_EQ(found.size(), 2U) << "one latch per injection";
  for (const auto& [first, end] : found) {
    ASSERT_GE(first, 50U);
    double before = 0.0;
    for (std::size_t i = first - 50; i < first; ++i) before = std::max(before, std::abs(applied[i]));
    EXPECT_GT(before, 0.01) << "a torque before the failure";
    // Seen by read() (the period's one transaction): zero in that period.
    for (std::size_t i = first; i < end; ++i) ASSERT_EQ(applied[i], 0.0) << "row " << i << " latched";
    ASSERT_LT(end, applied.size()) << "never resumed in the recording";
    // The scene restarts at equilibrium with the measured position: no step.
    EXPECT_LT(std::abs(applied[end]), 0.02) << "torque step at the resume, row " << end;
  }
}

TEST_P(ModbusEndToEnd, AKilledAmplifierZeroesTheOutputAndLatches) {
  auto amplifier = std::make_unique<AmplifierProcess>(GetParam(), swing_hand);
  const int port = amplifier->port();
  TempDir dir;
  const auto started = start_on_the_real_clock(dir, *amplifier, GetParam());
  Daemon& d = *started;
  ASSERT_TRUE(d.running()) << d.log();
  const auto start = d.ctl({"record", "start", "--path", "k.csv", "--json"});
  ASSERT_EQ(start.exit_code, 0) << start.err;
  const std::string csv = json::parse(start.out).value("path", "");
  std::this_thread::sleep_for(1000ms);
  ASSERT_EQ(status_of(d).value("state", ""), "running") << status_of(d).dump() << d.log();

  amplifier->kill_now();
  ASSERT_TRUE(within(3000ms, [&] { return status_of(d).value("state", "") == "fault"; })) << d.log();
  const json during = status_of(d);
  const std::string reason =
      during["device"]["fault_reason"].is_string() ? during["device"]["fault_reason"] : "";
  EXPECT_FALSE(reason.empty()) << during.dump();
  std::printf("modbus %s, amplifier killed: \"%s\"\n", name_of(GetParam()).c_str(), reason.c_str());
  const auto refused = d.ctl({"fault", "clear"});
  EXPECT_NE(refused.exit_code, 0) << "cleared with no amplifier: " << refused.out;
  EXPECT_EQ(status_of(d).value("state", ""), "fault");

  if (GetParam() == Transport::tcp) {
    // The amplifier back on its port: fault clear reconnects (off the RT thread).
    amplifier = std::make_unique<AmplifierProcess>(GetParam(), swing_hand, port);
    const auto cleared = d.ctl({"fault", "clear", "--json"});
    ASSERT_EQ(cleared.exit_code, 0) << cleared.err << cleared.out << d.log();
    EXPECT_NE(cleared.out.find("reconnected"), std::string::npos) << cleared.out;
    ASSERT_TRUE(within(3000ms, [&] { return status_of(d).value("state", "") == "running"; })) << d.log();
    std::this_thread::sleep_for(300ms);
    EXPECT_GT(amplifier->state()["steps"].get<long>(), 20) << "the new amplifier is driven (300 ms at 5 ms)";
  }
  ASSERT_EQ(d.ctl({"record", "stop"}).exit_code, 0);
  EXPECT_EQ(d.stop(), 0) << d.log();

  const Recording rec = read_recording(csv);
  const auto applied = rec.values("applied_n_m");
  const auto found = episodes(rec);
  ASSERT_GE(found.size(), 1U);
  const auto [first, end] = found.front();
  for (std::size_t i = first; i < end; ++i) ASSERT_EQ(applied[i], 0.0) << "row " << i << " latched";
  if (GetParam() == Transport::tcp) {
    ASSERT_LT(end, applied.size()) << "never resumed in the recording";
    EXPECT_LT(std::abs(applied[end]), 0.02) << "torque step at the resume";
  }
}

TEST_P(ModbusEndToEnd, AKilledHapticdLetsTheAmplifierWatchdogDisableIt) {
  AmplifierProcess amplifier(GetParam(), swing_hand);
  TempDir dir;
  const auto started = start_on_the_real_clock(dir, amplifier, GetParam());
  Daemon& d = *started;
  ASSERT_TRUE(d.running()) << d.log();
  std::this_thread::sleep_for(400ms);
  const json before = amplifier.state();
  ASSERT_TRUE(before["enabled"].get<bool>()) << before.dump() << "\n" << status_of(d).dump();
  ASSERT_TRUE(before["watchdog_armed"].get<bool>()) << before.dump();

  ::kill(d.pid(), SIGKILL);  // no close(): nothing disables the amplifier but its watchdog
  ASSERT_TRUE(within(2000ms, [&] { return amplifier.state()["watchdog_trips"] == 1; }))
      << amplifier.state().dump();
  const json after = amplifier.state();
  EXPECT_FALSE(after["enabled"].get<bool>()) << after.dump();
  EXPECT_EQ(after["torque"], 0.0) << after.dump();
  EXPECT_EQ(after["fault"].get<unsigned>() & (1u << 2), 1u << 2) << "the watchdog bit: " << after.dump();
  // watchdog_value in the amplifier's unit (ms) is the silence it takes.
  const double silence = after["trip_silence_s"].get<double>();
  EXPECT_GE(silence, watchdog_ms(GetParam()) * 1e-3) << after.dump();
  EXPECT_LT(silence, watchdog_ms(GetParam()) * 1e-3 + 0.5) << after.dump();
  std::printf("modbus %s, hapticd killed: the amplifier tripped after %.1f ms of silence\n",
              name_of(GetParam()).c_str(), silence * 1e3);
  EXPECT_EQ(d.stop(), -SIGKILL);
}

// Issue 17: holding registers whose position jumps by 2^31 counts once used
// to be taken as motion (no fault; torque at torque_limit until stop; no
// flag in the recording). The engine's position-step rule (max_velocity, for
// this wheel 50 + sqrt(2 x 0.8 N m x 2 pi / 0.01 kg m^2) = 81.7 rad/s)
// refuses it in the period it arrives.
// A hand that turns the wheel between 0 and 0.6 rad, never below 0: the
// 32-bit count, once offset by 2^31, then never crosses its wrap (2^31 counts
// with a hand about 0 would wrap at each zero crossing, a jump of 2^32 counts
// each time: a real counter's wrap, refused too).
const char* const turning_above_zero =
    "mode=hold trajectory=sine position=0.3 amplitude=0.3 frequency=1 phase=-1.5707963267948966";

TEST_P(ModbusEndToEnd, A2To31CountPositionJumpLatchesInItsPeriodWithTheFigures) {
  AmplifierProcess amplifier(GetParam(), turning_above_zero);
  TempDir dir;
  const auto started = start_on_the_real_clock(dir, amplifier, GetParam());
  Daemon& d = *started;
  ASSERT_TRUE(d.running()) << d.log();
  const auto start = d.ctl({"record", "start", "--path", "j.csv", "--json"});
  ASSERT_EQ(start.exit_code, 0) << start.err;
  const std::string csv = json::parse(start.out).value("path", "");
  std::this_thread::sleep_for(1000ms);
  ASSERT_EQ(status_of(d).value("state", ""), "running") << status_of(d).dump() << d.log();

  ASSERT_EQ(amplifier.command("position-jump 2147483648"), "ok");
  ASSERT_TRUE(within(3000ms, [&] { return status_of(d).value("state", "") == "fault"; })) << d.log();
  const json during = status_of(d);
  EXPECT_EQ(during["fault"], "encoder jump / velocity limit") << during.dump();
  EXPECT_TRUE(during["device"]["fault_reason"].is_null()) << "the amplifier itself has no fault";
  const json& detail = during["fault_detail"];
  ASSERT_TRUE(detail.is_object()) << during.dump();
  // The 32-bit count wraps: -2^31 or +2^31 counts, plus the hand's few counts of motion.
  EXPECT_NEAR(std::abs(detail["step_counts"].get<double>()), 2147483648.0, 50.0) << detail.dump();
  EXPECT_NEAR(detail["max_velocity"].get<double>(), 81.71, 0.01) << detail.dump();
  EXPECT_GE(detail["interval_s"].get<double>(), period_of(GetParam())) << detail.dump();
  EXPECT_NEAR(detail["limit"].get<double>(),
              detail["max_velocity"].get<double>() * detail["interval_s"].get<double>() + 2 * M_PI / 16384,
              1e-9);
  std::this_thread::sleep_for(100ms);
  EXPECT_EQ(amplifier.state()["torque_counts"], 0) << "latched: torque 0 at the amplifier";

  const auto cleared = d.ctl({"fault", "clear", "--json"});
  ASSERT_EQ(cleared.exit_code, 0) << cleared.err << cleared.out << d.log();
  EXPECT_EQ(json::parse(cleared.out)["cleared"], "encoder jump / velocity limit") << cleared.out;
  ASSERT_TRUE(within(3000ms, [&] { return status_of(d).value("state", "") == "running"; })) << d.log();
  std::this_thread::sleep_for(500ms);
  const json after = status_of(d);
  EXPECT_EQ(after.value("state", ""), "running") << "the offset position is the new normal: " << after.dump();
  ASSERT_EQ(d.ctl({"record", "stop"}).exit_code, 0);
  EXPECT_EQ(d.stop(), 0) << d.log();

  const Recording rec = read_recording(csv);
  const auto flags = rec.values("flags"), applied = rec.values("applied_n_m"),
             position = rec.values("position_rad");
  const auto found = episodes(rec);
  ASSERT_EQ(found.size(), 1U) << "one latch";
  const auto [first, end] = found.front();
  ASSERT_GE(first, 50U);
  EXPECT_NE(static_cast<unsigned>(flags[first]) & 32u, 0U) << "the latch's first sample is the jump's";
  EXPECT_GT(std::abs(position[first] - position[first - 1]), 800000.0);
  double before = 0.0;
  for (std::size_t i = first - 50; i < first; ++i) before = std::max(before, std::abs(applied[i]));
  EXPECT_GT(before, 0.01) << "a torque before the jump";
  for (std::size_t i = first; i < end; ++i) ASSERT_EQ(applied[i], 0.0) << "row " << i << " latched";
  ASSERT_LT(end, applied.size()) << "never resumed in the recording";
  EXPECT_LT(std::abs(applied[end]), 0.02) << "torque step at the resume, row " << end;
  for (std::size_t i = first; i < applied.size(); ++i)
    ASSERT_LT(std::abs(applied[i]), 0.8) << "row " << i << ": at torque_limit after the jump";
}

// Issue 17 item 9: a fault clear on the control thread waits up to
// connect_timeout for each exchange with the amplifier; one that stopped
// answering held the daemon's exit that long after SIGTERM. The amplifier
// here drops every request from the latch on; the clear is under way when
// SIGTERM comes. The design bound is 1 s; 3 s is asserted on this shared
// machine, and the figure printed.
TEST(ModbusSigterm, ASigtermDuringAFaultClearOnASilentAmplifierEndsTheDaemon) {
  AmplifierProcess amplifier(Transport::tcp, swing_hand);
  TempDir dir;
  const auto started = start_on_the_real_clock(dir, amplifier, Transport::tcp, "connect_timeout = \"20s\"\n");
  Daemon& d = *started;
  ASSERT_TRUE(d.running()) << d.log();
  std::this_thread::sleep_for(300ms);
  ASSERT_EQ(amplifier.command("timeout 1000000"), "ok");
  ASSERT_TRUE(within(3000ms, [&] { return status_of(d).value("state", "") == "fault"; })) << d.log();
  CommandResult clear;
  std::thread clearing([&] { clear = d.ctl({"fault", "clear"}); });
  std::this_thread::sleep_for(500ms);  // the clear waits (20 s) for the silent amplifier
  const auto sent = std::chrono::steady_clock::now();
  const int status = d.stop();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - sent).count();
  clearing.join();
  EXPECT_EQ(status, 0) << d.log();
  std::printf(
      "modbus tcp, fault clear waiting on a silent amplifier (connect_timeout 20 s): SIGTERM to exit "
      "%.3f s\n",
      seconds);
  EXPECT_LT(seconds, 3.0) << "the design bound is 1 s: " << d.log();
  EXPECT_NE(clear.exit_code, 0) << "the clear cannot have succeeded: " << clear.out;
  // Nothing reached the silent amplifier: its own watchdog (200 ms) takes the power stage off.
  EXPECT_TRUE(within(2000ms, [&] { return !amplifier.state()["enabled"].get<bool>(); }))
      << amplifier.state().dump();
}

std::string transport_name(const ::testing::TestParamInfo<Transport>& p) {
  return p.param == Transport::tcp ? "Tcp" : "Rtu";
}

INSTANTIATE_TEST_SUITE_P(ModbusEndToEnd, ModbusEndToEnd, ::testing::Values(Transport::tcp, Transport::rtu),
                         transport_name);

}  // namespace

}  // namespace modbus_e2e_test
