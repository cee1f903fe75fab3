// The usb-hid driver's own cost per period, and the two ways of handling
// libusb events (drivers/usb_hid/README.md "Event handling").
//
// Not measured here: anything through umockdev (an emulated ioctl is a
// round trip to the handler's thread, nothing like the kernel's usbfs), and
// the bus itself (no USB board on this machine). So:
//  - BM_Encode/Decode/SessionPeriod: codec and bookkeeping per period;
//  - BM_LoopModeIdlePoll: libusb_handle_events_timeout_completed with a
//    zero timeout on a real libusb context with no transfer pending, i.e.
//    the fixed cost loop mode adds to the RT thread (poll(2) on libusb's
//    event fd and timerfd, its locks) before any URB is reaped;
//  - BM_ThreadModeWakeup: what thread mode adds to each completion: the time
//    from an fd becoming ready (an eventfd written by the measuring thread,
//    standing in for usbfs signalling a completed URB) until a thread
//    blocked in poll(2) runs; percentiles as counters, both threads
//    SCHED_FIFO when allowed (RT thread 80, event thread 79).

#include <benchmark/benchmark.h>
#include <libusb.h>
#include <poll.h>
#include <pthread.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <thread>
#include <vector>

#include "drivers/usb_hid/host_session.hpp"
#include "drivers/usb_hid/report_codec.hpp"

using namespace hapticd::drivers;
using namespace hapticd::drivers::usb_hid;

namespace {

void BM_EncodeOut(benchmark::State& state) {
  const OutLayout layout;
  std::array<std::uint8_t, max_report_size> buffer{};
  OutReport r;
  r.enable = true;
  r.deadman_us = 3000;
  for (auto _ : state) {
    ++r.sequence;
    r.command[0] = static_cast<std::int64_t>(r.sequence & 0x3FFFU);
    benchmark::DoNotOptimize(encode_out(r, layout, buffer));
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_EncodeOut);

void BM_DecodeIn(benchmark::State& state) {
  const InLayout layout;
  std::array<std::uint8_t, 16> bytes{0x01, 0x02, 0x34, 0x12, 0x60, 0x79, 0xFE, 0xFF, 0x01};
  InReport r;
  for (auto _ : state) {
    ++bytes[0];
    benchmark::DoNotOptimize(decode_in(bytes, layout, r));
    benchmark::DoNotOptimize(r);
  }
}
BENCHMARK(BM_DecodeIn);

/// One period of the host protocol: one IN report in, the read closed, the
/// next OUT report built (what the device does per period besides libusb).
void BM_SessionPeriod(benchmark::State& state) {
  const ReportLayout layout;
  HostSession session(layout, SessionLimits{});
  std::array<std::uint8_t, 16> in{};
  std::array<std::uint8_t, max_report_size> out{};
  InReport board;
  board.enabled = true;
  InReport latest;
  for (auto _ : state) {
    ++board.sequence;
    board.ack = session.last_out_sequence();
    board.position_counts[0] += 3;
    encode_in(board, layout.in, in);
    session.on_in(TransferOutcome::completed, in, 0x81);
    benchmark::DoNotOptimize(session.end_read(latest));
    benchmark::DoNotOptimize(session.make_out(latest.position_counts[0], true, 3000, out));
  }
  state.counters["faulted"] = session.faulted() ? 1.0 : 0.0;
}
BENCHMARK(BM_SessionPeriod);

/// A board with `n` axes: consecutive i32 counts from byte 4 and i16
/// commands from byte 2, the other fields after them (the simulated board's
/// layout, drivers/usb_hid/README.md "Several axes").
ReportLayout axes_layout(std::size_t n) {
  ReportLayout l;
  l.in.size = std::max<std::size_t>(16, 6 + 4 * n);
  l.in.position = consecutive_fields(field(4, 4, true), n);
  l.in.enabled = bit_at(4 + 4 * n, 0);
  l.in.fault = bit_at(4 + 4 * n, 1);
  l.in.watchdog = bit_at(4 + 4 * n, 2);
  l.in.fault_code = field(5 + 4 * n, 1, false);
  l.out.size = 6 + 2 * n;
  l.out.command = consecutive_fields(field(2, 2, true), n);
  l.out.enable = bit_at(2 + 2 * n, 0);
  l.out.reset = bit_at(2 + 2 * n, 1);
  l.out.deadman = field(4 + 2 * n, 2, false);
  return l;
}

/// One period of the host protocol with N axes (Arg): the IN report with N
/// counts in, the read closed, the OUT report with N commands built.
void BM_SessionPeriodAxes(benchmark::State& state) {
  const auto n = static_cast<std::size_t>(state.range(0));
  const ReportLayout layout = axes_layout(n);
  validate(layout);
  HostSession session(layout, SessionLimits{});
  std::array<std::uint8_t, max_report_size> in{};
  std::array<std::uint8_t, max_report_size> out{};
  InReport board;
  board.enabled = true;
  InReport latest;
  std::array<std::int64_t, max_report_axes> commands{};
  for (auto _ : state) {
    ++board.sequence;
    board.ack = session.last_out_sequence();
    for (std::size_t k = 0; k < n; ++k) board.position_counts[k] += static_cast<std::int64_t>(k + 1);
    encode_in(board, layout.in, in);
    session.on_in(TransferOutcome::completed, std::span(in).first(layout.in.size), 0x81);
    benchmark::DoNotOptimize(session.end_read(latest));
    for (std::size_t k = 0; k < n; ++k) commands[k] = latest.position_counts[k] & 0x3FFF;
    benchmark::DoNotOptimize(
        session.make_out(std::span<const std::int64_t>(commands.data(), n), true, 3000, out));
  }
  state.counters["faulted"] = session.faulted() ? 1.0 : 0.0;
}
BENCHMARK(BM_SessionPeriodAxes)->Arg(1)->Arg(2)->Arg(6);

void BM_LoopModeIdlePoll(benchmark::State& state) {
  libusb_context* ctx = nullptr;
  if (libusb_init(&ctx) != 0) {
    state.SkipWithError("libusb_init failed");
    return;
  }
  timeval zero{};
  for (auto _ : state) benchmark::DoNotOptimize(libusb_handle_events_timeout_completed(ctx, &zero, nullptr));
  libusb_exit(ctx);
}
BENCHMARK(BM_LoopModeIdlePoll);

bool set_fifo(pthread_t thread, int priority) {
  sched_param p{};
  p.sched_priority = priority;
  return pthread_setschedparam(thread, SCHED_FIFO, &p) == 0;
}

void BM_ThreadModeWakeup(benchmark::State& state) {
  const int samples = static_cast<int>(state.range(0));
  const int efd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  std::atomic<std::int64_t> written_ns{0};
  std::vector<std::int64_t> latencies;
  latencies.reserve(static_cast<std::size_t>(samples));
  std::atomic<bool> quit{false};
  const auto now_ns = [] {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(
               std::chrono::steady_clock::now().time_since_epoch())
        .count();
  };
  std::thread event_thread([&] {
    pollfd fd{efd, POLLIN, 0};
    while (!quit.load(std::memory_order_acquire)) {
      if (poll(&fd, 1, 100) <= 0) continue;
      const std::int64_t woke = now_ns();
      std::uint64_t value = 0;
      if (read(efd, &value, sizeof value) == sizeof value)
        latencies.push_back(woke - written_ns.load(std::memory_order_acquire));
    }
  });
  const bool fifo = set_fifo(event_thread.native_handle(), 79) && set_fifo(pthread_self(), 80);
  for (auto _ : state) {
    for (int i = 0; i < samples; ++i) {
      written_ns.store(now_ns(), std::memory_order_release);
      const std::uint64_t one = 1;
      benchmark::DoNotOptimize(write(efd, &one, sizeof one));
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
  }
  quit.store(true, std::memory_order_release);
  event_thread.join();
  close(efd);
  sched_param normal{};
  pthread_setschedparam(pthread_self(), SCHED_OTHER, &normal);
  std::sort(latencies.begin(), latencies.end());
  const auto pct = [&](double q) {
    return latencies.empty()
               ? 0.0
               : static_cast<double>(
                     latencies[static_cast<std::size_t>(q * static_cast<double>(latencies.size() - 1))]) /
                     1000.0;
  };
  state.counters["samples"] = static_cast<double>(latencies.size());
  state.counters["fifo"] = fifo ? 1.0 : 0.0;
  state.counters["p50_us"] = pct(0.50);
  state.counters["p99_us"] = pct(0.99);
  state.counters["p999_us"] = pct(0.999);
  state.counters["max_us"] = pct(1.0);
}
BENCHMARK(BM_ThreadModeWakeup)->Arg(4000)->Iterations(1)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
