// gpio-pwm: the cost of each per-period operation of the driver, and the
// highest quadrature edge rate the decoding thread follows without loss.
//
// Run: build/bench/gpio_pwm_bench (re-executes itself under
// libumockdev-preload). What each figure measures:
//   BM_CounterRead, BM_DutyWrite: the sysfs transport's pread()/pwrite() on
//     tmpfs files: the system-call floor (a real sysfs attribute adds the
//     kernel's show()/store() and, for the PWM, the chip's register write);
//   BM_OutputsSet, BM_FaultQueueRead: libgpiod's ioctl and event read on the
//     umockdev chip: each is a round trip to umockdev's handler thread, so
//     this is the emulation's cost, far above a kernel ioctl;
//   BM_DecodeEdge: the quadrature decoder's cost per edge (pure);
//   BM_DevicePeriod/<counter>: the Device's read() + write() against the
//     simulated board, the whole per-period work of the driver (fault poll,
//     count pread or the decoded count, duty pwrite, outputs ioctl); the
//     board steps the shared plant simulator inside that ioctl (lockstep),
//     so this is an upper bound with the emulation's round trips in it.
//     period_fraction: the mean cost as a fraction of a 1 ms period;
//   BM_QuadratureEdgeRate: edges injected on the emulated A/B lines at a
//     paced real-time rate while the reader thread decodes; reports
//     lost=1 when any edge was dropped or mis-decoded; dropped: edges the
//     full 16-event queues dropped (the reader was kept away too long);
//     count_error: the largest final count error. Every read of an
//     event fd is a round trip to umockdev's handler thread, so this is the
//     emulation's limit on this machine, not the kernel's (see README:
//     32 counts per longest read gap).
#include <benchmark/benchmark.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <thread>

#include "drivers/device.hpp"
#include "drivers/gpio_pwm/gpio_lines.hpp"
#include "drivers/gpio_pwm/gpio_pwm_device.hpp"
#include "drivers/gpio_pwm/quadrature_decoder.hpp"
#include "drivers/gpio_pwm/sysfs_attributes.hpp"
#include "drivers/simulation/plant_simulator.hpp"
#include "sim/gpio_pwm/board.hpp"
#include "sim/gpio_pwm/quadrature_encoder.hpp"
#include "sim/gpio_pwm/umockdev_gpio_testbed.hpp"

namespace gp = hapticd::drivers::gpio_pwm;
namespace fs = std::filesystem;

namespace {

std::string temp_root() {
  std::string pattern =
      fs::is_directory("/dev/shm") ? "/dev/shm/gpio-pwm-bench.XXXXXX" : "/tmp/gpio-pwm-bench.XXXXXX";
  return ::mkdtemp(pattern.data());
}

// A PWM channel and a count as plain files, as the kernel lays them out.
struct PlainSysfs {
  std::string root = temp_root();
  PlainSysfs() {
    const std::string channel = root + "/pwmchip0/pwm0";
    fs::create_directories(channel);
    std::ofstream(root + "/pwmchip0/npwm") << "1\n";
    for (const char* a : {"period", "duty_cycle", "enable"}) std::ofstream(channel + "/" + a) << "0\n";
    std::ofstream(channel + "/polarity") << "normal\n";
    fs::create_directories(root + "/counter0/count0");
    std::ofstream(root + "/counter0/count0/count") << "123456\n";
  }
  ~PlainSysfs() { fs::remove_all(root); }
};

void BM_CounterRead(benchmark::State& state) {
  PlainSysfs files;
  gp::CounterInput counter(files.root + "/counter0", 0);
  std::uint64_t raw = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(counter.read(raw));
  }
  benchmark::DoNotOptimize(raw);
}
BENCHMARK(BM_CounterRead);

void BM_DutyWrite(benchmark::State& state) {
  PlainSysfs files;
  gp::PwmOutput pwm({files.root + "/pwmchip0", 0, 50'000, false, 1.0});
  std::uint64_t duty = 0;
  for (auto _ : state) {
    duty = duty == 12'500 ? 12'501 : 12'500;  // changes every period: one pwrite
    benchmark::DoNotOptimize(pwm.set_duty(duty));
  }
}
BENCHMARK(BM_DutyWrite);

gp::sim::GpioChipSpec chip_spec() {
  gp::sim::GpioChipSpec s;
  s.line_names = {"EN", "DIR", "FAULT", "ENC_A", "ENC_B", "PUMP", "", ""};
  return s;
}

void BM_OutputsSet(benchmark::State& state) {
  gp::sim::UmockdevGpioTestbed bed(chip_spec());
  gp::GpioChip chip(bed.chip_path());
  const unsigned offsets[] = {0, 1, 5};
  const int initial[] = {0, 0, 0};
  const std::string keys[] = {"enable_line", "direction_line", "charge_pump_line"};
  gp::OutputLines outputs(chip, offsets, initial, "bench", keys);
  int pump = 0;
  for (auto _ : state) {
    pump ^= 1;
    const int levels[] = {1, 1, pump};
    benchmark::DoNotOptimize(outputs.set(levels));
  }
}
BENCHMARK(BM_OutputsSet)->UseRealTime();

void BM_FaultQueueRead(benchmark::State& state) {
  gp::sim::UmockdevGpioTestbed bed(chip_spec());
  gp::GpioChip chip(bed.chip_path());
  gp::EdgeInput fault(chip, 2, "bench", "fault_line");
  std::array<gp::EdgeEvent, 16> events;
  for (auto _ : state) {
    benchmark::DoNotOptimize(fault.read(events));  // empty: EAGAIN
  }
}
BENCHMARK(BM_FaultQueueRead)->UseRealTime();

void BM_DecodeEdge(benchmark::State& state) {
  gp::sim::QuadratureEncoder encoder(0);
  std::vector<gp::sim::EncoderEdge> edges;
  encoder.move_to(4096, 0, 4'096'000, edges);
  std::vector<gp::EdgeEvent> a, b;
  for (const auto& e : edges)
    (e.line == gp::sim::EncoderLine::a ? a : b).push_back({e.timestamp_ns, e.level});
  for (auto _ : state) {
    gp::QuadratureDecoder decoder(0);
    decoder.edges(a, b);
    benchmark::DoNotOptimize(decoder.count());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(edges.size()));
}
BENCHMARK(BM_DecodeEdge);

// The driver's read() + write() for one period against the board: counter
// (range 1) or quadrature edges decoded by the reader thread (range 0).
void BM_DevicePeriod(benchmark::State& state) {
  constexpr double period_s = 1e-3;
  const bool counter = state.range(0) != 0;
  gp::sim::GpioChipSpec spec;
  spec.line_names = {"MOTOR_EN", "MOTOR_DIR", "MOTOR_NFAULT", "ENC_A",
                     "ENC_B",    "PUMP",      "BRAKE",        "MOTOR_RESET"};
  gp::sim::UmockdevGpioTestbed gpio(spec);
  gp::sim::SimulatedPwmChip pwm(gpio.root_dir(), "/sys/class/pwm/pwmchip0", 1);
  gp::sim::SimulatedCounter count(gpio.root_dir(), "/sys/bus/counter/devices/counter0", 0, 0xFFFFFFFF);
  gp::sim::BoardConfig board_config;
  board_config.wiring.fault = 2;
  board_config.wiring.fault_active_low = true;
  board_config.wiring.charge_pump = 5;
  board_config.wiring.brake = 6;
  board_config.wiring.reset = 7;
  if (!counter) {
    board_config.wiring.encoder_a = 3;
    board_config.wiring.encoder_b = 4;
  }
  board_config.amplifier = {1.2, 0};
  board_config.period_s = period_s;
  auto plant = hapticd::drivers::simulation::PlantConfig::defaults(hapticd::drivers::Motion::rotary);
  plant.damping = 0.002;
  plant.period_s = period_s;
  gp::sim::SimulatedBoard board(gpio, pwm, counter ? &count : nullptr, board_config,
                                std::make_unique<gp::sim::SimulatorPlant>(
                                    std::make_unique<hapticd::drivers::simulation::PlantSimulator>(plant)));
  gp::GpioPwmConfig c;
  c.chip = "gpiochip0";
  c.enable_line = gp::parse_line_spec("enable_line", "MOTOR_EN");
  c.direction_line = gp::parse_line_spec("direction_line", "MOTOR_DIR");
  c.fault_line = gp::parse_line_spec("fault_line", "MOTOR_NFAULT", true);
  c.charge_pump_line = gp::parse_line_spec("charge_pump_line", "PUMP");
  c.brake_line = gp::parse_line_spec("brake_line", "BRAKE");
  c.reset_line = gp::parse_line_spec("reset_line", "MOTOR_RESET");
  c.force_at_full_duty = 1.2;
  c.max_duty = 1.0;
  c.pwm_period_ns = 50'000;
  c.counts_per_unit = plant.counts;
  c.mass = plant.mass;
  if (counter) {
    c.counter = "/sys/bus/counter/devices/counter0";
  } else {
    c.encoder_a_line = gp::parse_line_spec("encoder_a_line", "ENC_A");
    c.encoder_b_line = gp::parse_line_spec("encoder_b_line", "ENC_B");
  }
  // Through the framework's Device, as the daemon drives it.
  hapticd::drivers::Device device("gpio-pwm", std::make_unique<gp::GpioPwmDevice>(c));
  device.configure({period_s});
  device.enable();
  hapticd::drivers::Reading reading;
  double torque = 0.1;
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) {
    benchmark::DoNotOptimize(device.read(reading));
    torque = -torque;  // a new duty and a direction change every period
    benchmark::DoNotOptimize(device.write(torque));
  }
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  device.disable();
  device.close();
  state.counters["period_fraction"] = elapsed / (static_cast<double>(state.iterations()) * period_s);
}
BENCHMARK(BM_DevicePeriod)->ArgName("counter")->Arg(1)->Arg(0)->UseRealTime();

// Edges at state.range(0) edges per second (both lines together), for
// 20 ms of real time (at least 64 edges), paced by sleeping to each edge's
// due time (late edges go at once, in a burst, as late interrupts would).
void BM_QuadratureEdgeRate(benchmark::State& state) {
  const double rate = static_cast<double>(state.range(0));
  bool lost = false;
  double achieved = 0.0;
  std::uint64_t dropped = 0;  // edges the emulated kernel queue dropped (full)
  std::int64_t count_error = 0;
  for (auto _ : state) {
    gp::sim::UmockdevGpioTestbed bed(chip_spec());
    gp::GpioChip chip(bed.chip_path());
    gp::EdgeInput a(chip, 3, "bench", "encoder_a_line");
    gp::EdgeInput b(chip, 4, "bench", "encoder_b_line");
    gp::QuadratureReader reader(a, b, false, false, false);
    reader.start();
    gp::sim::QuadratureEncoder encoder(0);
    const auto edges_total = static_cast<std::int64_t>(std::max(64.0, rate * 0.02));
    std::vector<gp::sim::EncoderEdge> edges;
    encoder.move_to(edges_total, 0, static_cast<std::uint64_t>(static_cast<double>(edges_total) * 1e9 / rate),
                    edges);
    const auto start = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < edges.size(); ++i) {
      const auto due =
          start + std::chrono::nanoseconds(static_cast<std::int64_t>(static_cast<double>(i) * 1e9 / rate));
      std::this_thread::sleep_until(due);  // the edges come from hardware: this thread must not take a CPU
      const auto& e = edges[i];
      bed.drive_input(e.line == gp::sim::EncoderLine::a ? 3 : 4, e.level, e.timestamp_ns);
    }
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    achieved = static_cast<double>(edges.size()) / seconds;
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
    while (reader.count() != edges_total && std::chrono::steady_clock::now() < deadline)
      std::this_thread::yield();
    reader.stop();
    const auto s = reader.stats();
    lost = lost || reader.count() != edges_total || bed.dropped_events() != 0 || s.full_reads != 0 ||
           s.lost_edges != 0 || s.invalid_transitions != 0;
    dropped += bed.dropped_events();
    count_error = std::max(count_error, std::abs(reader.count() - edges_total));
  }
  state.counters["lost"] = lost ? 1.0 : 0.0;
  state.counters["edges_per_s"] = achieved;
  state.counters["dropped"] = static_cast<double>(dropped);
  state.counters["count_error"] = static_cast<double>(count_error);
}
BENCHMARK(BM_QuadratureEdgeRate)
    ->Arg(1'000)
    ->Arg(2'000)
    ->Arg(3'000)
    ->Arg(5'000)
    ->Arg(7'000)
    ->Arg(10'000)
    ->Arg(20'000)
    ->Arg(50'000)
    ->Iterations(3)
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  if (!gp::sim::ensure_umockdev_preload(argc, argv)) return 1;
  if (std::getenv("TMPDIR") == nullptr && fs::is_directory("/dev/shm")) ::setenv("TMPDIR", "/dev/shm", 1);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
