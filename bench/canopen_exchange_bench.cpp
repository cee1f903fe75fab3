// The canopen driver's per-period frame exchange against the simulated CiA
// 402 drive (its bus loop in a thread, over the unix SOCK_SEQPACKET seam):
//   BM_CanopenExchangeLogic  the pure per-period codec and logic (TPDO in,
//                            RPDO + SYNC out; arg 1: with the velocity TPDO2),
//                            CPU time per period and in ppm of a 1 ms period
//   BM_CanopenBusBudget      the period's frames on the bus, worst-case
//                            stuffing plus one blocking frame (bus_budget.hpp),
//                            at 1 Mbit/s: bits, bus time and its ratio to the
//                            period, per period (args: period us, TPDO2)
//   BM_CanopenPeriod         the RT side as the loop runs it: the framework's
//                            Device read() + write() over the driver's hooks
//                            on the socket, every period, in real time
//   BM_CanopenRoundTrip      RPDO + SYNC out until the drive's TPDO is back,
//                            which must happen well inside the period
// Percentiles (us and as a fraction of the period) are counters.
//
// Environment: HAPTICD_CANOPEN_CYCLES (default 5000), HAPTICD_CANOPEN_PERIOD_US (default 1000).

#include <benchmark/benchmark.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <thread>
#include <vector>

#include "drivers/canopen/canopen_device.hpp"
#include "drivers/canopen/cyclic_exchange.hpp"
#include "drivers/device.hpp"
#include "sim/canopen/drive_bus.hpp"
#include "sim/canopen/simulated_drive.hpp"

namespace canopen = hapticd::drivers::canopen;
namespace sim = hapticd::drivers::canopen::sim;
namespace co = hapticd::drivers::canopen::cia301;
using Clock = std::chrono::steady_clock;

namespace {

double thread_cpu_s() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_nsec) * 1e-9;
}

long env_long(const char* name, long fallback) {
  const char* v = std::getenv(name);
  return v && *v ? std::strtol(v, nullptr, 10) : fallback;
}

class RigidPlant final : public sim::DrivePlant {
 public:
  explicit RigidPlant(double period) : period_(period) {}
  double position() const override { return x_; }
  double velocity() const override { return v_; }
  void step(double force) override {
    const double a = (force - 0.05 * v_) / 0.01;
    x_ += v_ * period_ + 0.5 * a * period_ * period_;
    v_ += a * period_;
  }

 private:
  double period_;
  double x_ = 0.0, v_ = 0.0;
};

/// The simulated drive's bus program in a thread.
struct SimulatedBus {
  explicit SimulatedBus(double period)
      : path(
            (std::filesystem::temp_directory_path() / ("hapticd-canopen-bench-" + std::to_string(::getpid())))
                .string()),
        plant(period),
        drive(settings(), plant),
        bus(path, drive),
        thread([this] { bus.run(stop); }) {}
  ~SimulatedBus() {
    stop = true;
    thread.join();
  }
  static sim::DriveSettings settings() {
    sim::DriveSettings s;
    s.node_id = 5;
    s.rated_torque_mnm = 500;
    return s;
  }
  std::string path;
  RigidPlant plant;
  sim::SimulatedDrive drive;
  sim::DriveBus bus;
  std::atomic<bool> stop{false};
  std::thread thread;
};

void report(benchmark::State& state, std::vector<double> us, double period_us) {
  std::sort(us.begin(), us.end());
  auto pct = [&](double p) {
    const auto rank = static_cast<std::size_t>(std::ceil(p * static_cast<double>(us.size())));
    return us[std::max<std::size_t>(rank, 1) - 1];
  };
  state.counters["p50_us"] = pct(0.50);
  state.counters["p99_us"] = pct(0.99);
  state.counters["max_us"] = us.back();
  state.counters["p50_of_period"] = pct(0.50) / period_us;
  state.counters["p99_of_period"] = pct(0.99) / period_us;
  state.counters["max_of_period"] = us.back() / period_us;
  state.counters["cycles"] = static_cast<double>(us.size());
}

canopen::CanopenConfig bench_config(const std::string& path) {
  canopen::CanopenConfig c;
  c.interface = "unix:" + path;
  c.node_id = 5;
  c.tpdo_timeout_periods = 1000;  // a vCPU stall of the VM must not end the run
  c.heartbeat_timeout = 0.5;
  c.sdo_timeout = 0.5;
  return c;
}

void BM_CanopenExchangeLogic(benchmark::State& state) {
  const bool velocity = state.range(0) != 0;
  canopen::CyclicSettings s;
  s.node = 5;
  s.mapping = canopen::standard_mapping(5, velocity);
  s.scaling.si_per_count = 1e-4;
  s.scaling.si_per_velocity_unit = 1e-4;
  s.scaling.force_per_permille = 5e-4;
  s.tpdo_timeout_periods = 1000;
  canopen::CyclicExchange x(s);
  x.set_enabled(true);
  co::Frame tpdo;
  tpdo.id = s.mapping.tpdo_position_id;
  tpdo.len = 6;
  tpdo.data = {0x37, 0x12, 0, 0, 0, 0, 0, 0};  // statusword Operation Enabled, position
  co::Frame tpdo2;
  tpdo2.id = s.mapping.tpdo_velocity_id;
  tpdo2.len = 4;
  std::array<co::Frame, 4> out;
  std::int32_t position = 0;
  const double cpu0 = thread_cpu_s();
  for (auto _ : state) {
    co::put_le(tpdo.data, 2, static_cast<std::uint32_t>(++position), 4);
    x.on_frame(tpdo);
    if (velocity) x.on_frame(tpdo2);
    benchmark::DoNotOptimize(x.begin_period());
    benchmark::DoNotOptimize(x.end_period(0.1, out));
  }
  const double cpu_per_period = (thread_cpu_s() - cpu0) / static_cast<double>(state.iterations());
  state.counters["cpu_ns"] = cpu_per_period * 1e9;
  state.counters["cpu_ppm_of_1ms"] = cpu_per_period / 1e-3 * 1e6;
}
BENCHMARK(BM_CanopenExchangeLogic)->Arg(0)->Arg(1);

/// Not a timing: the bus budget the driver's configure() checks, as counters
/// next to the timings so one run gives both (README "Bus budget").
void BM_CanopenBusBudget(benchmark::State& state) {
  const double period_s = static_cast<double>(state.range(0)) * 1e-6;
  const bool velocity = state.range(1) != 0;
  const auto frames = canopen::cyclic_frames(canopen::standard_mapping(5, velocity));
  co::BusBudget b;
  for (auto _ : state) {
    b = co::check_bus_budget(frames, period_s, co::max_classic_bitrate);
    benchmark::DoNotOptimize(b);
  }
  state.counters["frames"] = static_cast<double>(b.frames);
  state.counters["cyclic_bits"] = b.cyclic_bits;
  state.counters["total_bits"] = b.total_bits;  // + one 8-byte blocking frame
  state.counters["bus_us_at_1Mbit"] = b.bus_time_s * 1e6;
  state.counters["bus_of_period"] = b.bus_time_s / period_s;
  state.counters["cyclic_of_period"] =
      b.cyclic_bits / static_cast<double>(co::max_classic_bitrate) / period_s;
  state.counters["fits"] = b.fits ? 1 : 0;
  state.SetLabel(b.summary);
}
BENCHMARK(BM_CanopenBusBudget)->ArgsProduct({{250, 400, 500, 1000, 2000}, {0, 1}});

void BM_CanopenPeriod(benchmark::State& state) {
  const auto cycles = static_cast<std::size_t>(env_long("HAPTICD_CANOPEN_CYCLES", 5000));
  const double period_us = static_cast<double>(env_long("HAPTICD_CANOPEN_PERIOD_US", 1000));
  for (auto _ : state) {
    SimulatedBus bus(period_us * 1e-6);
    hapticd::drivers::Device device("canopen",
                                    std::make_unique<canopen::CanopenDevice>(bench_config(bus.path)));
    device.configure({period_us * 1e-6});
    device.enable();
    std::vector<double> us(cycles);
    const auto period =
        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::micro>(period_us));
    auto next = Clock::now();
    const auto start = next;
    for (std::size_t i = 0; i < cycles; ++i) {
      const auto t0 = Clock::now();
      hapticd::drivers::Reading r;
      device.read(r);
      device.write(0.05 * std::sin(static_cast<double>(i) * 1e-2));
      us[i] = std::chrono::duration<double, std::micro>(Clock::now() - t0).count();
      next += period;
      std::this_thread::sleep_until(next);
    }
    state.SetIterationTime(std::chrono::duration<double>(Clock::now() - start).count());
    state.counters["late_tpdos"] =
        static_cast<double>(device.hooks_as<canopen::CanopenDevice>().exchange_status().counters.late_tpdos);
    state.counters["faults"] = static_cast<double>(device.status().faults);
    device.close();
    report(state, us, period_us);
  }
}
BENCHMARK(BM_CanopenPeriod)->Iterations(1)->UseManualTime()->Unit(benchmark::kMillisecond);

void BM_CanopenRoundTrip(benchmark::State& state) {
  const auto cycles = static_cast<std::size_t>(env_long("HAPTICD_CANOPEN_CYCLES", 5000));
  const double period_us = static_cast<double>(env_long("HAPTICD_CANOPEN_PERIOD_US", 1000));
  for (auto _ : state) {
    SimulatedBus bus(period_us * 1e-6);
    // The driver's hooks configure the drive; then this loop drives the
    // exchange by hand on its own socket to time each SYNC's TPDO.
    canopen::CanopenDevice hooks(bench_config(bus.path));
    hooks.configure({period_us * 1e-6});
    const canopen::CyclicMapping mapping = hooks.setup().mapping;
    const canopen::Scaling scaling = hooks.scaling();
    hooks.close();  // leaves the drive configured, pre-operational
    const canopen::CanFilter filters[] = {canopen::exact_standard_filter(mapping.tpdo_position_id)};
    canopen::CanSocket socket = canopen::CanSocket::open("unix:" + bus.path, filters, 0);
    socket.send(co::encode_nmt(co::NmtCommand::start, 5));
    canopen::CyclicSettings s;
    s.node = 5;
    s.mapping = mapping;
    s.scaling = scaling;
    s.tpdo_timeout_periods = 1000;
    canopen::CyclicExchange x(s);
    std::vector<double> us;
    us.reserve(cycles);
    std::size_t lost = 0;
    const auto period =
        std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double, std::micro>(period_us));
    auto next = Clock::now();
    const auto start = next;
    std::array<co::Frame, 4> out;
    for (std::size_t i = 0; i < cycles; ++i) {
      x.begin_period();
      const std::size_t n = x.end_period(0.0, out);
      const auto t0 = Clock::now();
      for (std::size_t k = 0; k < n; ++k) socket.send(out[k]);
      co::Frame f;
      bool got = false;
      while (!got && Clock::now() < next + period) {
        if (socket.receive(f) == canopen::IoStatus::ok) {
          got = f.id == mapping.tpdo_position_id;
          x.on_frame(f);
        } else {
          socket.wait_readable(std::chrono::microseconds(200));
        }
      }
      if (got) {
        us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count());
      } else {
        ++lost;
      }
      next += period;
      std::this_thread::sleep_until(next);
    }
    state.SetIterationTime(std::chrono::duration<double>(Clock::now() - start).count());
    state.counters["no_tpdo_within_period"] = static_cast<double>(lost);
    report(state, us, period_us);
  }
}
BENCHMARK(BM_CanopenRoundTrip)->Iterations(1)->UseManualTime()->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
