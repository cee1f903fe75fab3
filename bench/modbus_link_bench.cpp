// Modbus link budget: the computed RTU cycle for 9600 baud to 4 Mbaud with
// the shortest period each rate carries, and the measured TCP transaction
// round trip on loopback against the simulated amplifier (its own process),
// as fractions of the period, for the two ways a loop can use one libmodbus
// context:
//   direct     the loop thread makes the fc 23 transaction itself;
//   io-thread  the loop thread hands the command to a dedicated I/O thread
//              (atomic + futex wake) and waits for its result (atomic wait).
// Not a Google Benchmark: the figures are per-period percentiles of a paced
// loop, like the wake-up latency of bench/latency.sh.
//
//   modbus_link_bench [CYCLES [PERIOD_US]]   (defaults 5000, 1000)
// Runs SCHED_FIFO 80 with memory locked when permitted, plain otherwise
// (says which).

#include <sched.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>
#include <vector>

#include "drivers/modbus/modbus_config.hpp"
#include "drivers/modbus/modbus_link.hpp"
#include "drivers/modbus/register_map.hpp"
#include "drivers/modbus/rtu_timing.hpp"
#include "drivers/simulation/plant_simulator.hpp"
#include "sim/modbus/amplifier_server.hpp"
#include "sim/modbus/simulator_plant.hpp"

namespace mb = hapticd::drivers::modbus;

namespace {

std::int64_t now_ns() {
  timespec t{};
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t.tv_sec * 1'000'000'000LL + t.tv_nsec;
}

void sleep_until(std::int64_t ns) {
  timespec t{static_cast<time_t>(ns / 1'000'000'000LL), static_cast<long>(ns % 1'000'000'000LL)};
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &t, nullptr) == EINTR) {
  }
}

struct Percentiles {
  double p50 = 0, p99 = 0, max = 0;
};

Percentiles percentiles(std::vector<std::int64_t> ns) {
  std::sort(ns.begin(), ns.end());
  auto at = [&](double p) {
    const auto i = static_cast<std::size_t>(std::min<double>(
        static_cast<double>(ns.size() - 1), std::ceil(p * static_cast<double>(ns.size())) - 1));
    return static_cast<double>(ns[i]) * 1e-9;
  };
  return {at(0.50), at(0.99), static_cast<double>(ns.back()) * 1e-9};
}

class PlantPort final : public mb::sim::AmplifierPlant {
 public:
  PlantPort() : simulator_(hapticd::drivers::simulation::PlantConfig{}), port_(simulator_) {}
  hapticd::drivers::IoResult sense(double& position) noexcept override { return port_.sense(position); }
  double velocity() const noexcept override { return port_.velocity(); }
  hapticd::drivers::IoResult step(double force) noexcept override { return port_.step(force); }

 private:
  hapticd::drivers::simulation::PlantSimulator simulator_;
  mb::sim::SimulatorPlant port_;
};

// The simulated amplifier in a child process; returns its pid and port.
pid_t start_amplifier(const mb::ModbusConfig& config, int& port) {
  int fds[2];
  if (pipe(fds) != 0) std::exit(1);
  const pid_t pid = fork();
  if (pid == 0) {
    close(fds[0]);
    // An amplifier is its own hardware: give the simulated one a real-time
    // priority (below the loop's) so the host's other work does not stand in
    // for amplifier latency.
    sched_param sp{};
    sp.sched_priority = 70;
    sched_setscheduler(0, SCHED_FIFO, &sp);
    mlockall(MCL_CURRENT | MCL_FUTURE);
    PlantPort plant;
    mb::sim::AmplifierSettings s;
    s.position_per_count = config.position_per_count();
    s.torque_per_count = config.torque_per_count;
    mb::sim::Amplifier amplifier(s, plant);
    auto server = mb::sim::AmplifierServer::tcp(amplifier);
    server->start();
    const int p = server->port();
    if (write(fds[1], &p, sizeof p) != sizeof p) _exit(1);
    close(fds[1]);
    pause();
    _exit(0);
  }
  close(fds[1]);
  if (read(fds[0], &port, sizeof port) != sizeof port) std::exit(1);
  close(fds[0]);
  return pid;
}

bool make_realtime() {
  sched_param sp{};
  sp.sched_priority = 80;
  const bool fifo = sched_setscheduler(0, SCHED_FIFO, &sp) == 0;
  mlockall(MCL_CURRENT | MCL_FUTURE);
  return fifo;
}

void print_rtu_table(const mb::ModbusConfig& c, const mb::LayoutResult& layout, double period_s) {
  const int w = layout.layout.write_count, r = layout.layout.read_count;
  std::printf(
      "RTU budget, fc 23 (write %d, read %d registers: %d + %d bytes), 8E1, turnaround 0, link_budget %.2f, "
      "T = %.3f ms\n",
      w, r, mb::rtu_bytes::write_and_read_request(w), mb::rtu_bytes::write_and_read_response(r),
      c.link_budget, period_s * 1e3);
  std::printf(
      "| baud | char | t3.5 spec | cycle (spec) | cycle/T (spec) | shortest period (spec) | t3.5 chars | "
      "cycle (chars) | cycle/T (chars) | shortest period (chars) |\n");
  std::printf("|---|---|---|---|---|---|---|---|---|---|\n");
  int n = 0;
  const int* bauds = mb::supported_bauds(n);
  for (int i = 0; i < n; ++i) {
    if (bauds[i] < 9600) continue;
    mb::SerialFormat f = c.serial;
    f.baud = bauds[i];
    const auto spec = mb::cycle_time(f, mb::SilenceRule::spec, 0.0, true, w, r);
    const auto chars = mb::cycle_time(f, mb::SilenceRule::characters, 0.0, true, w, r);
    std::printf(
        "| %d | %.2f us | %.3f ms | %.3f ms | %.3f | %.3f ms | %.3f ms | %.3f ms | %.3f | %.3f ms |\n",
        bauds[i], mb::character_time_s(f) * 1e6, spec.first.silence_s * 1e3, spec.total_s() * 1e3,
        spec.total_s() / period_s, mb::shortest_period_s(spec, c.link_budget) * 1e3,
        chars.first.silence_s * 1e3, chars.total_s() * 1e3, chars.total_s() / period_s,
        mb::shortest_period_s(chars, c.link_budget) * 1e3);
  }
}

}  // namespace

int main(int argc, char** argv) {
  const int cycles = argc > 1 ? std::atoi(argv[1]) : 5000;
  const std::int64_t period_ns = (argc > 2 ? std::atoll(argv[2]) : 1000) * 1000;
  const mb::ModbusConfig config = mb::modbus_config({});
  const mb::LayoutResult layout = mb::plan_blocks(config.map);
  print_rtu_table(config, layout, static_cast<double>(period_ns) * 1e-9);

  int port = 0;
  const pid_t amplifier = start_amplifier(config, port);
  mb::LinkSettings s;
  s.transport = mb::Transport::tcp;
  s.port = port;
  // A whole period, so the distribution is measured rather than cut at the
  // driver's response timeout (link_budget x period).
  s.response_timeout_s = static_cast<double>(period_ns) * 1e-9;
  mb::ModbusLink link(s);
  link.open();
  const bool fifo = make_realtime();
  std::printf("\nTCP on 127.0.0.1, simulated amplifier in its own process, %d cycles at %.3f ms, %s\n",
              cycles, static_cast<double>(period_ns) * 1e-6,
              fifo ? "SCHED_FIFO 80, memory locked" : "SCHED_OTHER (no permission for SCHED_FIFO)");

  const auto& l = layout.layout;
  std::array<std::uint16_t, 2> command{0, config.map.watchdog_value};
  std::array<std::uint16_t, 6> state{};
  auto transact = [&] {
    return link.write_and_read(l.write_address, std::span(command).first(l.write_count), l.read_address,
                               std::span(state).first(l.read_count));
  };

  // Direct: the loop thread makes the transaction.
  std::vector<std::int64_t> direct;
  direct.reserve(static_cast<std::size_t>(cycles));
  int failures = 0;
  std::int64_t next = now_ns() + period_ns;
  for (int i = 0; i < cycles; ++i) {
    sleep_until(next);
    next += period_ns;
    const std::int64_t t0 = now_ns();
    if (!transact().ok()) ++failures;
    direct.push_back(now_ns() - t0);
  }

  // I/O thread: the loop thread posts the command and waits for the result.
  std::atomic<std::uint32_t> posted{0}, done{0};
  std::atomic<bool> stop{false};
  std::thread io([&] {
    if (fifo) {
      sched_param sp{};
      sp.sched_priority = 79;
      sched_setscheduler(0, SCHED_FIFO, &sp);
    }
    std::uint32_t seen = 0;
    for (;;) {
      posted.wait(seen);
      if (stop.load()) return;
      seen = posted.load();
      if (!transact().ok()) ++failures;
      done.store(seen);
      done.notify_one();
    }
  });
  std::vector<std::int64_t> handed;
  handed.reserve(static_cast<std::size_t>(cycles));
  next = now_ns() + period_ns;
  for (std::uint32_t i = 1; i <= static_cast<std::uint32_t>(cycles); ++i) {
    sleep_until(next);
    next += period_ns;
    const std::int64_t t0 = now_ns();
    posted.store(i);
    posted.notify_one();
    for (std::uint32_t d = done.load(); d != i; d = done.load()) done.wait(d);
    handed.push_back(now_ns() - t0);
  }
  stop.store(true);
  posted.fetch_add(1);
  posted.notify_one();
  io.join();
  kill(amplifier, SIGTERM);
  waitpid(amplifier, nullptr, 0);

  const double T = static_cast<double>(period_ns) * 1e-9;
  std::printf("| mode | p50 | p99 | max | p50/T | p99/T | max/T |\n|---|---|---|---|---|---|---|\n");
  for (auto [name, v] : {std::pair{"direct", &direct}, std::pair{"io-thread", &handed}}) {
    const Percentiles p = percentiles(*v);
    std::printf("| %s | %.1f us | %.1f us | %.1f us | %.3f | %.3f | %.3f |\n", name, p.p50 * 1e6, p.p99 * 1e6,
                p.max * 1e6, p.p50 / T, p.p99 / T, p.max / T);
  }
  const double budget = config.link_budget * static_cast<double>(period_ns) * 1e-9;
  for (auto [name, v] : {std::pair{"direct", &direct}, std::pair{"io-thread", &handed}}) {
    const auto over = std::count_if(v->begin(), v->end(),
                                    [&](std::int64_t ns) { return static_cast<double>(ns) * 1e-9 > budget; });
    std::printf(
        "%s: %ld of %d transactions longer than link_budget x T = %.0f us (a timeout at the default "
        "response timeout)\n",
        name, static_cast<long>(over), cycles, budget * 1e6);
  }
  const auto& k = link.counters();
  std::printf("timeouts %llu, malformed %llu\n", static_cast<unsigned long long>(k.timeouts.load()),
              static_cast<unsigned long long>(k.bad_frames.load()));
  std::printf("failed transactions: %d of %d; frames: %llu requests, %llu responses\n", failures, 2 * cycles,
              static_cast<unsigned long long>(link.counters().requests.load()),
              static_cast<unsigned long long>(link.counters().responses.load()));
  return failures == 0 ? 0 : 1;
}
