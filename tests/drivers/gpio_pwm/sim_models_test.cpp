// The simulated board's models follow the kernel: GPIO uAPI v1 request
// rules and values, PWM sysfs apply rules, encoder edge sequences.
#include <gtest/gtest.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <string>

#include "sim/gpio_pwm/amplifier.hpp"
#include "sim/gpio_pwm/gpio_chip_model.hpp"
#include "sim/gpio_pwm/kernel_sysfs_text.hpp"
#include "sim/gpio_pwm/pwm_channel_model.hpp"
#include "sim/gpio_pwm/quadrature_encoder.hpp"

namespace hapticd::drivers::gpio_pwm::sim::sim_models_test {
namespace {

GpioChipModel chip() {
  return GpioChipModel("gpiochip0", "hapticd-sim", {"EN", "DIR", "FAULT", "A", "B", "", "", ""});
}

gpiohandle_request handle(std::initializer_list<unsigned> offsets, std::uint32_t flags) {
  gpiohandle_request r{};
  unsigned i = 0;
  for (unsigned o : offsets) r.lineoffsets[i++] = o;
  r.lines = i;
  r.flags = flags;
  std::strcpy(r.consumer_label, "test");
  return r;
}

TEST(GpioChipModel, ChipAndLineInfo) {
  GpioChipModel c = chip();
  gpiochip_info ci{};
  ASSERT_EQ(c.chip_info(ci), 0);
  EXPECT_STREQ(ci.name, "gpiochip0");
  EXPECT_STREQ(ci.label, "hapticd-sim");
  EXPECT_EQ(ci.lines, 8u);
  gpioline_info li{};
  li.line_offset = 1;
  ASSERT_EQ(c.line_info(li), 0);
  EXPECT_STREQ(li.name, "DIR");
  EXPECT_EQ(li.flags, 0u);
  li.line_offset = 8;
  EXPECT_EQ(c.line_info(li), EINVAL);
}

TEST(GpioChipModel, HandleRequestFlagRulesOfTheKernel) {
  GpioChipModel c = chip();
  EXPECT_EQ(c.request_handle(1, handle({0}, GPIOHANDLE_REQUEST_INPUT | GPIOHANDLE_REQUEST_OUTPUT)), EINVAL);
  EXPECT_EQ(c.request_handle(1, handle({0}, GPIOHANDLE_REQUEST_INPUT | GPIOHANDLE_REQUEST_OPEN_DRAIN)),
            EINVAL);
  EXPECT_EQ(c.request_handle(1, handle({0}, GPIOHANDLE_REQUEST_OUTPUT | GPIOHANDLE_REQUEST_OPEN_DRAIN |
                                                GPIOHANDLE_REQUEST_OPEN_SOURCE)),
            EINVAL);
  EXPECT_EQ(c.request_handle(1, handle({0}, GPIOHANDLE_REQUEST_BIAS_PULL_UP)),
            EINVAL);  // bias without direction
  EXPECT_EQ(c.request_handle(1, handle({0}, GPIOHANDLE_REQUEST_INPUT | GPIOHANDLE_REQUEST_BIAS_PULL_UP |
                                                GPIOHANDLE_REQUEST_BIAS_PULL_DOWN)),
            EINVAL);
  EXPECT_EQ(c.request_handle(1, handle({0}, 1U << 12)), EINVAL);
  EXPECT_EQ(c.request_handle(1, handle({8}, GPIOHANDLE_REQUEST_OUTPUT)), EINVAL);
  gpiohandle_request none = handle({}, GPIOHANDLE_REQUEST_OUTPUT);
  EXPECT_EQ(c.request_handle(1, none), EINVAL);
  EXPECT_FALSE(c.requested(0));
}

TEST(GpioChipModel, OutputsWithActiveLowAndBusyLines) {
  GpioChipModel c = chip();
  gpiohandle_request r = handle({0, 1}, GPIOHANDLE_REQUEST_OUTPUT | GPIOHANDLE_REQUEST_ACTIVE_LOW);
  r.default_values[0] = 1;
  r.default_values[1] = 0;
  ASSERT_EQ(c.request_handle(7, r), 0);
  EXPECT_FALSE(c.physical_level(0));  // logical 1, active low
  EXPECT_TRUE(c.physical_level(1));
  EXPECT_EQ(c.request_handle(8, handle({1, 2}, GPIOHANDLE_REQUEST_INPUT)), EBUSY);
  EXPECT_FALSE(c.requested(2));  // nothing of a refused request is kept
  gpiohandle_data v{};
  v.values[0] = 0;
  v.values[1] = 1;
  ASSERT_EQ(c.set_values(7, v), 0);
  EXPECT_TRUE(c.physical_level(0));
  EXPECT_FALSE(c.physical_level(1));
  gpiohandle_data back{};
  ASSERT_EQ(c.get_values(7, back), 0);
  EXPECT_EQ(back.values[0], 0);
  EXPECT_EQ(back.values[1], 1);
  gpioline_info li{};
  li.line_offset = 0;
  ASSERT_EQ(c.line_info(li), 0);
  EXPECT_EQ(li.flags, GPIOLINE_FLAG_KERNEL | GPIOLINE_FLAG_IS_OUT | GPIOLINE_FLAG_ACTIVE_LOW);
  EXPECT_STREQ(li.consumer, "test");
  c.release(7);
  EXPECT_FALSE(c.requested(0));
  EXPECT_EQ(c.request_handle(8, handle({1, 2}, GPIOHANDLE_REQUEST_INPUT)), 0);
}

TEST(GpioChipModel, SetValuesOnAnInputHandleIsEperm) {
  GpioChipModel c = chip();
  ASSERT_EQ(c.request_handle(1, handle({3}, GPIOHANDLE_REQUEST_INPUT)), 0);
  gpiohandle_data v{};
  EXPECT_EQ(c.set_values(1, v), EPERM);
  EXPECT_EQ(c.set_values(99, v), EBADF);
}

TEST(GpioChipModel, EventRequestsAndEdgeIds) {
  GpioChipModel c = chip();
  gpioevent_request e{};
  e.lineoffset = 2;
  e.handleflags = GPIOHANDLE_REQUEST_OUTPUT;
  e.eventflags = GPIOEVENT_REQUEST_BOTH_EDGES;
  EXPECT_EQ(c.request_event(1, e), EINVAL);  // no events on outputs
  e.handleflags = GPIOHANDLE_REQUEST_INPUT | GPIOHANDLE_REQUEST_ACTIVE_LOW;
  e.eventflags = 1U << 5;
  EXPECT_EQ(c.request_event(1, e), EINVAL);
  e.eventflags = GPIOEVENT_REQUEST_BOTH_EDGES;
  ASSERT_EQ(c.request_event(1, e), 0);
  // Active low: the pin going low is a logical rising edge.
  c.drive_input(2, true, 5);  // from low to high physical: logical falling
  auto ev = c.drive_input(2, false, 10);
  ASSERT_TRUE(ev.has_value());
  EXPECT_EQ(ev->request, 1u);
  EXPECT_EQ(ev->data.id, GPIOEVENT_EVENT_RISING_EDGE);
  EXPECT_EQ(ev->data.timestamp, 10u);
  EXPECT_FALSE(c.drive_input(2, false, 11).has_value());  // no change, no event
  gpiohandle_data v{};
  ASSERT_EQ(c.get_values(1, v), 0);
  EXPECT_EQ(v.values[0], 1);

  gpioevent_request rising{};
  rising.lineoffset = 3;
  rising.handleflags = GPIOHANDLE_REQUEST_INPUT;
  rising.eventflags = GPIOEVENT_REQUEST_RISING_EDGE;
  ASSERT_EQ(c.request_event(2, rising), 0);
  EXPECT_TRUE(c.drive_input(3, true, 20).has_value());
  EXPECT_FALSE(c.drive_input(3, false, 30).has_value());  // falling not asked for
}

// lib/kstrtox.c as the PWM sysfs stores call it (base 0), and sysfs_streq.
TEST(KernelSysfsText, KstrtoxRules) {
  std::uint64_t v = 0;
  EXPECT_EQ(kernel_kstrtoull("50000\n", 0, v), 0);
  EXPECT_EQ(v, 50000U);
  EXPECT_EQ(kernel_kstrtoull("0x1F4", 0, v), 0);  // base 0: hex after 0x
  EXPECT_EQ(v, 500U);
  EXPECT_EQ(kernel_kstrtoull("010", 0, v), 0);  // and octal after a 0
  EXPECT_EQ(v, 8U);
  EXPECT_EQ(kernel_kstrtoull("+7", 0, v), 0);
  EXPECT_EQ(v, 7U);
  EXPECT_EQ(kernel_kstrtoull("18446744073709551615", 10, v), 0);
  EXPECT_EQ(v, UINT64_MAX);
  EXPECT_EQ(kernel_kstrtoull("18446744073709551616", 10, v), ERANGE);
  for (const char* refused : {"", "\n", "-1", " 5", "5 ", "5\n\n", "5\n0", "0x", "08", "abc", "1.5"})
    EXPECT_EQ(kernel_kstrtoull(refused, 0, v), EINVAL) << '"' << refused << '"';
  unsigned u = 0;
  EXPECT_EQ(kernel_kstrtouint("4294967296", 0, u), ERANGE);
  int i = 0;
  EXPECT_EQ(kernel_kstrtoint("-2147483648", 0, i), 0);
  EXPECT_EQ(i, INT32_MIN);
  EXPECT_EQ(kernel_kstrtoint("2147483648", 0, i), ERANGE);
  EXPECT_EQ(kernel_kstrtoint("-0x10\n", 0, i), 0);
  EXPECT_EQ(i, -16);
  EXPECT_TRUE(kernel_sysfs_streq("normal\n", "normal"));
  EXPECT_TRUE(kernel_sysfs_streq("normal", "normal"));
  EXPECT_FALSE(kernel_sysfs_streq("normal\n\n", "normal"));
  EXPECT_FALSE(kernel_sysfs_streq("normal\nx", "normal"));
  char text[21];
  EXPECT_EQ(std::string(text, kernel_print_llu(UINT64_MAX, text, sizeof text)), "18446744073709551615\n");
  EXPECT_EQ(std::string(text, kernel_print_llu(0, text, sizeof text)), "0\n");
}

TEST(PwmChannelModel, TakesWhatTheKernelsStoresTake) {
  PwmChannelModel m;
  EXPECT_EQ(m.write("period", "0xC350"), 0);  // 50000, no newline
  EXPECT_EQ(m.write("duty_cycle", "99999999999999999999\n"), ERANGE);
  EXPECT_EQ(m.write("enable", "-1\n"), EINVAL);
  EXPECT_EQ(m.write("enable", "01\n"), 0);
  EXPECT_EQ(m.state(), (PwmChannelState{50'000, 0, true, false}));
}

TEST(PwmChannelModel, KernelApplyRules) {
  PwmChannelModel m;                            // freshly exported: period 0
  EXPECT_EQ(m.write("enable", "0\n"), EINVAL);  // period 0 refused whatever field changes
  EXPECT_EQ(m.write("polarity", "inversed\n"), EINVAL);
  EXPECT_EQ(m.write("duty_cycle", "0\n"), EINVAL);
  EXPECT_EQ(m.write("period", "50000\n"), 0);
  EXPECT_EQ(m.write("duty_cycle", "50001\n"), EINVAL);
  EXPECT_EQ(m.write("duty_cycle", "50000\n"), 0);
  EXPECT_EQ(m.write("period", "40000\n"), EINVAL);  // would leave duty above period
  EXPECT_EQ(m.write("period", "0\n"), EINVAL);
  EXPECT_EQ(m.write("enable", "2\n"), EINVAL);
  EXPECT_EQ(m.write("enable", "1\n"), 0);
  EXPECT_EQ(m.write("polarity", "inversed\n"), EBUSY);
  EXPECT_EQ(m.write("polarity", "normal\n"), 0);  // unchanged: fine while enabled
  EXPECT_EQ(m.write("polarity", "sideways\n"), EINVAL);
  EXPECT_EQ(m.write("duty_cycle", "abc\n"), EINVAL);
  EXPECT_EQ(m.write("frequency", "1\n"), ENOENT);
  EXPECT_EQ(m.state(), (PwmChannelState{50'000, 50'000, true, false}));
  EXPECT_EQ(m.read("period"), "50000\n");
  EXPECT_EQ(m.read("enable"), "1\n");
  EXPECT_EQ(m.read("polarity"), "normal\n");
  EXPECT_DOUBLE_EQ(m.high_fraction(), 1.0);
}

TEST(QuadratureEncoderModel, EdgesFollowThePublishedSequence) {
  QuadratureEncoder e(0);
  std::vector<EncoderEdge> edges;
  e.move_to(4, 1000, 2000, edges);
  const std::vector<EncoderEdge> expected{{EncoderLine::a, true, 1250},
                                          {EncoderLine::b, true, 1500},
                                          {EncoderLine::a, false, 1750},
                                          {EncoderLine::b, false, 2000}};
  EXPECT_EQ(edges, expected);
  edges.clear();
  e.move_to(2, 2000, 2100, edges);  // backward: B rises first
  const std::vector<EncoderEdge> back{{EncoderLine::b, true, 2050}, {EncoderLine::a, true, 2100}};
  EXPECT_EQ(edges, back);
  EXPECT_EQ(e.state(), (EncoderPhase{true, true}));
  EXPECT_EQ(QuadratureEncoder::state_of(-1), (EncoderPhase{false, true}));
}

TEST(Amplifier, DrivesOnlyWhenEnabledNotBrakingNotFaulted) {
  Amplifier amp({0.8, 0});
  AmplifierInputs in{true, true, false, false, 0.25};
  EXPECT_DOUBLE_EQ(amp.step(in), 0.2);
  in.direction_positive = false;
  EXPECT_DOUBLE_EQ(amp.step(in), -0.2);
  in.enable = false;
  EXPECT_DOUBLE_EQ(amp.step(in), 0.0);
  in.enable = true;
  in.brake = true;
  EXPECT_DOUBLE_EQ(amp.step(in), 0.0);
  EXPECT_FALSE(amp.powered());
  in.brake = false;
  amp.trip("over-current");
  EXPECT_DOUBLE_EQ(amp.step(in), 0.0);
  EXPECT_TRUE(amp.fault());
  EXPECT_EQ(amp.fault_reason(), "over-current");
  amp.set_reset(true);
  EXPECT_TRUE(amp.fault());  // cleared at the end of the pulse, not its start
  amp.set_reset(false);
  EXPECT_FALSE(amp.fault());
  EXPECT_EQ(amp.resets(), 1u);
  EXPECT_DOUBLE_EQ(amp.step(in), -0.2);
}

TEST(Amplifier, ChargePumpWatchdogCutsThePowerWhenTheWaveStops) {
  Amplifier amp({1.0, 3});
  AmplifierInputs in{true, true, false, false, 0.5};
  EXPECT_DOUBLE_EQ(amp.step(in), 0.0);  // no wave yet: not armed
  for (int period = 0; period < 10; ++period) {
    in.charge_pump = !in.charge_pump;  // toggled every period, as the driver does
    EXPECT_DOUBLE_EQ(amp.step(in), 0.5) << period;
  }
  EXPECT_EQ(amp.pump_edges(), 10u);
  // The controller stops (killed): the line keeps its last level.
  for (int period = 1; period <= 3; ++period) EXPECT_DOUBLE_EQ(amp.step(in), 0.5) << period;
  EXPECT_DOUBLE_EQ(amp.step(in), 0.0);
  EXPECT_TRUE(amp.watchdog_expired());
  in.charge_pump = !in.charge_pump;
  EXPECT_DOUBLE_EQ(amp.step(in), 0.5);  // the wave is back
}

}  // namespace
}  // namespace hapticd::drivers::gpio_pwm::sim::sim_models_test
