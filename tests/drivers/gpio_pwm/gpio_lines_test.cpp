// The driver's GPIO transport (gpio_lines.hpp) through libgpiod, on the
// umockdev testbed and, where the kernel has it, on gpio-sim: chip lookup
// and errors, lines by offset or name, the bulk output request, edge
// inputs, and the quadrature reader thread fed by the simulated encoder.
#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <chrono>
#include <functional>
#include <random>
#include <thread>

#include "drivers/gpio_pwm/gpio_lines.hpp"
#include "sim/gpio_pwm/quadrature_encoder.hpp"
#include "sim/gpio_pwm/umockdev_gpio_testbed.hpp"
#include "tests/drivers/gpio_pwm/line_backends.hpp"
#include "tests/support/alloc_counter.hpp"

namespace hapticd::drivers::gpio_pwm::gpio_lines_test {
namespace {

using testing_support::LineBackend;

const std::vector<std::string> line_names{"MOTOR_EN", "MOTOR_DIR", "MOTOR_FAULT", "ENC_A",
                                          "ENC_B",    "PUMP",      "BRAKE",       "RESET"};

bool eventually(const std::function<bool()>& condition) {
  for (int i = 0; i < 5000; ++i) {
    if (condition()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return condition();
}

class GpioLines : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    if (GetParam() == "gpio-sim") {
      if (const std::string why = testing_support::gpio_sim_unavailable_reason(); !why.empty())
        GTEST_SKIP() << why;
    }
    bed_ = testing_support::make_line_backend(GetParam(), line_names);
  }
  bool physical(unsigned offset) { return bed_->output_level(offset); }
  std::unique_ptr<LineBackend> bed_;
};

TEST_P(GpioLines, OpensTheChipAndDescribesIt) {
  GpioChip chip(bed_->chip_path());
  EXPECT_EQ(chip.num_lines(), 8u);
  EXPECT_EQ(chip.describe(), chip.name() + " (" + chip.label() + ", 8 lines)");
  if (bed_->is_testbed()) {
    EXPECT_EQ(chip.describe(), "gpiochip0 (hapticd-sim, 8 lines)");
  }
  try {
    GpioChip missing("gpiochip99");
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.key(), "chip");
    EXPECT_NE(std::string(e.what()).find("no such GPIO chip"), std::string::npos) << e.what();
  }
}

TEST_P(GpioLines, ResolvesLinesByOffsetOrName) {
  GpioChip chip(bed_->chip_path());
  EXPECT_EQ(chip.resolve(parse_line_spec("enable_line", "5"), "enable_line"), 5u);
  EXPECT_EQ(chip.resolve(parse_line_spec("fault_line", "MOTOR_FAULT"), "fault_line"), 2u);
  try {
    chip.resolve(parse_line_spec("brake_line", "8"), "brake_line");
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.key(), "brake_line");
    EXPECT_EQ(
        std::string(e.what()),
        "brake_line = 8: gpiochip0 (hapticd-sim, 8 lines) has no line 8; accepted: 0 to 7 or a line name");
  }
  try {
    chip.resolve(parse_line_spec("reset_line", "NRESET"), "reset_line");
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.key(), "reset_line");
    EXPECT_NE(std::string(e.what()).find("no line of that name"), std::string::npos) << e.what();
  }
}

TEST_P(GpioLines, OutputsAreOneRequestSetByOneCall) {
  GpioChip chip(bed_->chip_path());
  const unsigned offsets[] = {0, 1, 5};
  const int initial[] = {0, 1, 0};
  const std::string keys[] = {"enable_line", "direction_line", "charge_pump_line"};
  OutputLines outputs(chip, offsets, initial, "hapticd", keys);
  EXPECT_FALSE(physical(0));
  EXPECT_TRUE(physical(1));
  const LineInfo info = chip.info(5);
  EXPECT_TRUE(info.used);
  EXPECT_EQ(info.consumer, "hapticd");
  const int levels[] = {1, 0, 1};
  const std::uint64_t before = bed_->requests_served();
  ASSERT_EQ(outputs.set(levels), 0);
  if (bed_->is_testbed()) {
    EXPECT_EQ(bed_->requests_served() - before, 1u);  // one ioctl for all three
  }
  EXPECT_TRUE(physical(0) && !physical(1) && physical(5));
  int back[3] = {};
  ASSERT_EQ(outputs.get(back), 0);
  EXPECT_EQ(back[0], 1);
  EXPECT_EQ(back[1], 0);
  EXPECT_EQ(back[2], 1);
}

TEST_P(GpioLines, SettingOutputsDoesNotAllocate) {
  GpioChip chip(bed_->chip_path());
  const unsigned offsets[] = {0, 1};
  const int initial[] = {0, 0};
  const std::string keys[] = {"enable_line", "direction_line"};
  OutputLines outputs(chip, offsets, initial, "hapticd", keys);
  int failed = 0;
  testing::AllocationGuard guard;
  for (int i = 0; i < 200; ++i) {
    const int levels[] = {i & 1, (i >> 1) & 1};
    failed += outputs.set(levels) != 0;
  }
  const auto allocations = guard.count();
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(failed, 0) << "set() calls that failed";
}

TEST_P(GpioLines, ALineInUseIsRefusedWithItsConsumer) {
  GpioChip chip(bed_->chip_path());
  const unsigned first[] = {6};
  const int level[] = {0};
  const std::string first_keys[] = {"test"};
  OutputLines brake(chip, first, level, "pwm-fan", first_keys);
  GpioChip again(bed_->chip_path());
  const unsigned offsets[] = {0, 6};
  const int initial[] = {0, 0};
  const std::string keys[] = {"enable_line", "brake_line"};
  try {
    OutputLines outputs(again, offsets, initial, "hapticd", keys);
    FAIL();
  } catch (const TransportError& e) {
    EXPECT_EQ(e.key(), "brake_line");
    EXPECT_EQ(std::string(e.what()),
              "brake_line = 6 (BRAKE) on gpiochip0 (hapticd-sim, 8 lines) is in use by \"pwm-fan\"; "
              "accepted: a free "
              "line");
  }
}

TEST_P(GpioLines, EdgeInputReadsQueuedEdgesWithoutBlocking) {
  GpioChip chip(bed_->chip_path());
  EdgeInput fault(chip, 2, "hapticd", "fault_line");
  std::array<EdgeEvent, 16> events;
  EXPECT_EQ(fault.read(events), 0);  // nothing queued: no wait
  EXPECT_EQ(fault.level(), 0);
  bed_->drive_input(2, true, 1000);
  bed_->drive_input(2, false, 2000);
  bed_->drive_input(2, true, 3000);
  ASSERT_TRUE(eventually([&] { return fault.level() == 1; }));
  ASSERT_EQ(fault.read(events), 3);
  EXPECT_TRUE(events[0].rising);
  EXPECT_FALSE(events[1].rising);
  EXPECT_TRUE(events[2].rising);
  EXPECT_LT(events[0].timestamp_ns, events[1].timestamp_ns);
  EXPECT_LT(events[1].timestamp_ns, events[2].timestamp_ns);
  if (bed_->is_testbed()) {
    EXPECT_EQ(events[0].timestamp_ns, 1000u);
    EXPECT_EQ(events[2].timestamp_ns, 3000u);
  }
  EXPECT_EQ(fault.read(events), 0);
  EXPECT_EQ(fault.level(), 1);
  int not_empty = 0;
  testing::AllocationGuard guard;
  for (int i = 0; i < 100; ++i) not_empty += fault.read(events) != 0;
  const auto allocations = guard.count();
  EXPECT_EQ(allocations, 0u);
  EXPECT_EQ(not_empty, 0) << "reads that failed or found events nobody queued";
}

// Drives the simulated encoder's edges onto the two lines.
void drive_encoder(LineBackend& bed, sim::QuadratureEncoder& encoder, std::int64_t target, std::uint64_t& t,
                   bool invert_a = false) {
  std::vector<sim::EncoderEdge> edges;
  encoder.move_to(target, t, t + 1'000'000, edges);
  t += 1'000'000;
  for (const auto& e : edges) {
    const bool a = e.line == sim::EncoderLine::a;
    bed.drive_input(a ? 3 : 4, a && invert_a ? !e.level : e.level, e.timestamp_ns);
  }
}

TEST_P(GpioLines, QuadratureReaderFollowsTheEncoder) {
  GpioChip chip(bed_->chip_path());
  EdgeInput a(chip, 3, "hapticd", "encoder_a_line");
  EdgeInput b(chip, 4, "hapticd", "encoder_b_line");
  QuadratureReader reader(a, b, false, false, false);
  reader.start();
  sim::QuadratureEncoder encoder(0);
  std::uint64_t t = 0;
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> step(-12, 12);  // below the 16-event queue per line
  std::int64_t target = 0;
  for (int period = 0; period < 300; ++period) {
    target += step(rng);
    drive_encoder(*bed_, encoder, target, t);
    ASSERT_TRUE(eventually([&] { return reader.count() == target; })) << "period " << period;
  }
  reader.stop();
  const auto stats = reader.stats();
  EXPECT_EQ(stats.invalid_transitions, 0u);
  EXPECT_EQ(stats.lost_edges, 0u);
  EXPECT_EQ(stats.full_reads, 0u);
  EXPECT_EQ(bed_->dropped_events(), 0u);
  EXPECT_GT(stats.edges, 0u);
}

TEST_P(GpioLines, QuadratureReaderStartsFromTheLinesLevelsAndHonoursActiveLow) {
  // The encoder rests at count 2 (A and B high) before the driver starts;
  // line A is wired inverted (active low).
  sim::QuadratureEncoder encoder(0);
  std::uint64_t t = 0;
  drive_encoder(*bed_, encoder, 2, t, true);
  GpioChip chip(bed_->chip_path());
  EdgeInput a(chip, 3, "hapticd", "encoder_a_line");
  EdgeInput b(chip, 4, "hapticd", "encoder_b_line");
  QuadratureReader reader(a, b, true, false, true);  // reverse: counts down for A leading B
  reader.start();
  drive_encoder(*bed_, encoder, 7, t, true);
  EXPECT_TRUE(eventually([&] { return reader.count() == -5; })) << reader.count();
  EXPECT_EQ(reader.stats().invalid_transitions + reader.stats().lost_edges, 0u);
}

// Regression: the reader took B's queue after A's, so an A edge that
// arrived between the two reads was decoded after a later B edge (a paced
// injection showed counts lost without any error). Here the edges B+(2),
// A-(3), B-(4) arrive exactly after the reader took A+(1) from A's queue and
// before it looks at B's.
TEST(QuadratureReaderOrder, AnEdgeArrivingBetweenTheTwoReadsIsDecodedInOrder) {
  sim::GpioChipSpec spec;
  spec.line_names = line_names;
  sim::UmockdevGpioTestbed bed(spec);
  GpioChip chip(bed.chip_path());
  EdgeInput a(chip, 3, "hapticd", "encoder_a_line");
  EdgeInput b(chip, 4, "hapticd", "encoder_b_line");
  QuadratureReader reader(a, b, false, false, false);
  std::atomic<bool> injected{false};
  bed.set_read_observer([&](unsigned offset) {
    if (offset != 3 || injected.exchange(true)) return;
    bed.drive_input(4, true, 2);   // B+
    bed.drive_input(3, false, 3);  // A-
    bed.drive_input(4, false, 4);  // B-
  });
  reader.start();
  bed.drive_input(3, true, 1);  // A+: wakes the reader
  ASSERT_TRUE(eventually([&] { return reader.stats().edges >= 4; }));
  reader.stop();
  bed.set_read_observer(nullptr);
  EXPECT_TRUE(injected.load());
  EXPECT_EQ(reader.count(), 4);
  EXPECT_EQ(reader.stats().invalid_transitions + reader.stats().lost_edges, 0u);
}

// Regression: edges that keep coming faster than the reader's passes. Each
// read of A brings the encoder's next two edges, A's then B's, so no pass
// finds both queues empty, and each pass takes that B edge while the older A
// edge waits in A's queue. After 8 passes the reader decoded the batch whole,
// so the waiting A edge was decoded after the newer B edge: counted the
// wrong way with no error. Decoded only up to the older line's newest edge,
// the rest carried, the count is exact.
TEST(QuadratureReaderOrder, EdgesFasterThanThePassesAreDecodedInOrder) {
  sim::GpioChipSpec spec;
  spec.line_names = line_names;
  sim::UmockdevGpioTestbed bed(spec);
  GpioChip chip(bed.chip_path());
  EdgeInput a(chip, 3, "hapticd", "encoder_a_line");
  EdgeInput b(chip, 4, "hapticd", "encoder_b_line");
  QuadratureReader reader(a, b, false, false, false);
  constexpr std::int64_t counts = 400;
  sim::QuadratureEncoder encoder(0);
  std::vector<sim::EncoderEdge> edges;
  encoder.move_to(counts, 1'000, 1'000 + 1'000 * counts, edges);
  std::atomic<std::size_t> next{2};
  bed.set_read_observer([&](unsigned offset) {
    if (offset != 3) return;
    for (int k = 0; k < 2; ++k) {
      const std::size_t i = next.fetch_add(1);
      if (i >= edges.size()) return;
      bed.drive_input(edges[i].line == sim::EncoderLine::a ? 3 : 4, edges[i].level, edges[i].timestamp_ns);
    }
  });
  ASSERT_EQ(edges[0].line, sim::EncoderLine::a);  // A leads B counting up
  bed.drive_input(3, edges[0].level, edges[0].timestamp_ns);
  bed.drive_input(4, edges[1].level, edges[1].timestamp_ns);
  reader.start();
  EXPECT_TRUE(eventually([&] { return reader.count() == counts; })) << reader.count();
  reader.stop();
  bed.set_read_observer(nullptr);
  EXPECT_GE(next.load(), edges.size());
  EXPECT_EQ(bed.dropped_events(), 0u);
  EXPECT_EQ(reader.stats().invalid_transitions + reader.stats().lost_edges, 0u);
}

// Edges beyond a line's 16 queued events are lost, as in the kernel. A
// read that finds a full queue is counted (the sure sign); the decoder then
// sees a line report the level it already has when the loss is not whole
// cycles (whole cycles lost leave no trace in the levels).
TEST_P(GpioLines, QueueOverflowIsCountedAndShowsAsLostEdges) {
  GpioChip chip(bed_->chip_path());
  EdgeInput a(chip, 3, "hapticd", "encoder_a_line");
  EdgeInput b(chip, 4, "hapticd", "encoder_b_line");
  QuadratureReader reader(a, b, false, false, false);
  // Not started: 101 counts = 51 edges on A, 50 on B; each queue keeps 16.
  sim::QuadratureEncoder encoder(0);
  std::uint64_t t = 0;
  drive_encoder(*bed_, encoder, 101, t);
  if (bed_->is_testbed()) {
    EXPECT_EQ(bed_->dropped_events(), 69u);
  }
  reader.start();
  ASSERT_TRUE(eventually([&] { return reader.stats().edges >= 32; }));
  EXPECT_EQ(reader.count(), 32);  // what the queues held: 16 edges per line
  drive_encoder(*bed_, encoder, 103, t);
  ASSERT_TRUE(eventually([&] { return reader.stats().edges >= 34; }));
  reader.stop();
  EXPECT_EQ(reader.stats().full_reads, 2u);
  EXPECT_GT(reader.stats().lost_edges, 0u);
  EXPECT_NE(reader.count(), 103);
}

INSTANTIATE_TEST_SUITE_P(Chips, GpioLines, ::testing::Values("umockdev", "gpio-sim"),
                         [](const ::testing::TestParamInfo<std::string>& chip) {
                           return chip.param == "gpio-sim" ? std::string("GpioSim") : std::string("Umockdev");
                         });

}  // namespace
}  // namespace hapticd::drivers::gpio_pwm::gpio_lines_test
