// libgpiod 1.6 itself, unmodified, against the umockdev-emulated
// /dev/gpiochip0: chip info, line info, lookup by name, line handle and
// line event requests, values, events, the 16-event queue, release.
#include <fcntl.h>
#include <gpiod.h>
#include <gtest/gtest.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <functional>
#include <thread>

#include "sim/gpio_pwm/umockdev_gpio_testbed.hpp"

namespace hapticd::drivers::gpio_pwm::sim::libgpiod_testbed_test {
namespace {

GpioChipSpec spec() {
  GpioChipSpec s;
  s.line_names = {"MOTOR_EN", "MOTOR_DIR", "MOTOR_FAULT", "ENC_A", "ENC_B", "PUMP", "", ""};
  return s;
}

// Waits (bounded) for the testbed to see a request's file closed: umockdev
// reports the dropped connection on its worker thread.
bool eventually(const std::function<bool()>& condition) {
  for (int i = 0; i < 2000; ++i) {
    if (condition()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return condition();
}

class LibgpiodTestbed : public ::testing::Test {
 protected:
  void SetUp() override {
    chip_ = gpiod_chip_open(bed_.chip_path().c_str());
    ASSERT_NE(chip_, nullptr) << "gpiod_chip_open: " << std::strerror(errno);
  }
  void TearDown() override {
    if (chip_ != nullptr) gpiod_chip_close(chip_);
  }
  UmockdevGpioTestbed bed_{spec()};
  gpiod_chip* chip_ = nullptr;
};

TEST_F(LibgpiodTestbed, ChipInfo) {
  EXPECT_STREQ(gpiod_chip_name(chip_), "gpiochip0");
  EXPECT_STREQ(gpiod_chip_label(chip_), "hapticd-sim");
  EXPECT_EQ(gpiod_chip_num_lines(chip_), 8u);
}

// Lookup by label is not tested: libgpiod finds labels by scandir("/dev"),
// and glibc's scandir opens the directory internally, past the preload, so
// it lists the real /dev.
TEST_F(LibgpiodTestbed, ChipLookupByNameNumberAndPath) {
  for (const char* descr : {"gpiochip0", "0", "/dev/gpiochip0"}) {
    gpiod_chip* c = gpiod_chip_open_lookup(descr);
    ASSERT_NE(c, nullptr) << descr << ": " << std::strerror(errno);
    EXPECT_STREQ(gpiod_chip_name(c), "gpiochip0");
    gpiod_chip_close(c);
  }
  EXPECT_EQ(gpiod_chip_open_lookup("gpiochip7"), nullptr);
}

TEST_F(LibgpiodTestbed, LineInfoAndLookupByName) {
  gpiod_line* line = gpiod_chip_get_line(chip_, 1);
  ASSERT_NE(line, nullptr);
  EXPECT_STREQ(gpiod_line_name(line), "MOTOR_DIR");
  EXPECT_EQ(gpiod_line_consumer(line), nullptr);
  EXPECT_FALSE(gpiod_line_is_used(line));
  EXPECT_EQ(gpiod_line_direction(line), GPIOD_LINE_DIRECTION_INPUT);
  gpiod_line* fault = gpiod_chip_find_line(chip_, "MOTOR_FAULT");
  ASSERT_NE(fault, nullptr);
  EXPECT_EQ(gpiod_line_offset(fault), 2u);
  errno = 0;
  EXPECT_EQ(gpiod_chip_find_line(chip_, "NO_SUCH_LINE"), nullptr);
  EXPECT_EQ(errno, ENOENT);
  EXPECT_EQ(gpiod_chip_get_line(chip_, 8), nullptr);
  EXPECT_EQ(errno, EINVAL);
}

TEST_F(LibgpiodTestbed, BulkOutputRequestSetAndGet) {
  gpiod_line_bulk bulk;
  gpiod_line_bulk_init(&bulk);
  for (unsigned offset : {0u, 1u, 5u}) gpiod_line_bulk_add(&bulk, gpiod_chip_get_line(chip_, offset));
  const int defaults[] = {0, 1, 0};
  ASSERT_EQ(gpiod_line_request_bulk_output(&bulk, "hapticd", defaults), 0) << std::strerror(errno);
  EXPECT_FALSE(bed_.with_chip([](GpioChipModel& c) { return c.physical_level(0); }));
  EXPECT_TRUE(bed_.with_chip([](GpioChipModel& c) { return c.physical_level(1); }));

  const int values[] = {1, 0, 1};
  ASSERT_EQ(gpiod_line_set_value_bulk(&bulk, values), 0) << std::strerror(errno);
  EXPECT_TRUE(bed_.with_chip(
      [](GpioChipModel& c) { return c.physical_level(0) && !c.physical_level(1) && c.physical_level(5); }));
  int back[3] = {-1, -1, -1};
  ASSERT_EQ(gpiod_line_get_value_bulk(&bulk, back), 0);
  EXPECT_EQ(back[0], 1);
  EXPECT_EQ(back[1], 0);
  EXPECT_EQ(back[2], 1);

  gpiod_line* line = gpiod_chip_get_line(chip_, 5);
  EXPECT_TRUE(gpiod_line_is_used(line));
  EXPECT_STREQ(gpiod_line_consumer(line), "hapticd");
  EXPECT_EQ(gpiod_line_direction(line), GPIOD_LINE_DIRECTION_OUTPUT);
  gpiod_line_release_bulk(&bulk);
  EXPECT_TRUE(eventually([&] { return !bed_.with_chip([](GpioChipModel& c) { return c.requested(5); }); }));
}

TEST_F(LibgpiodTestbed, ActiveLowOutput) {
  gpiod_line* line = gpiod_chip_get_line(chip_, 0);
  gpiod_line_request_config config{"hapticd", GPIOD_LINE_REQUEST_DIRECTION_OUTPUT,
                                   GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW};
  ASSERT_EQ(gpiod_line_request(line, &config, 1), 0) << std::strerror(errno);
  EXPECT_FALSE(bed_.with_chip([](GpioChipModel& c) { return c.physical_level(0); }));
  EXPECT_EQ(gpiod_line_active_state(line), GPIOD_LINE_ACTIVE_STATE_LOW);
  ASSERT_EQ(gpiod_line_set_value(line, 0), 0);
  EXPECT_TRUE(bed_.with_chip([](GpioChipModel& c) { return c.physical_level(0); }));
}

TEST_F(LibgpiodTestbed, BusyLineIsRefusedUntilReleased) {
  gpiod_line* line = gpiod_chip_get_line(chip_, 1);
  ASSERT_EQ(gpiod_line_request_output(line, "first", 0), 0);
  // A second chip handle, as another program would have.
  gpiod_chip* other = gpiod_chip_open(bed_.chip_path().c_str());
  ASSERT_NE(other, nullptr);
  gpiod_line* same = gpiod_chip_get_line(other, 1);
  errno = 0;
  EXPECT_EQ(gpiod_line_request_output(same, "second", 0), -1);
  EXPECT_EQ(errno, EBUSY);
  gpiod_line_release(line);
  ASSERT_TRUE(eventually([&] { return !bed_.with_chip([](GpioChipModel& c) { return c.requested(1); }); }));
  EXPECT_EQ(gpiod_line_request_output(same, "second", 1), 0) << std::strerror(errno);
  gpiod_chip_close(other);
}

TEST_F(LibgpiodTestbed, SetValueOnAnInputIsRefused) {
  gpiod_line* line = gpiod_chip_get_line(chip_, 3);
  ASSERT_EQ(gpiod_line_request_input(line, "hapticd"), 0);
  errno = 0;
  EXPECT_EQ(gpiod_line_set_value(line, 1), -1);
  EXPECT_EQ(errno, EPERM);
  bed_.drive_input(3, true, 1);
  EXPECT_EQ(gpiod_line_get_value(line), 1);
}

TEST_F(LibgpiodTestbed, EdgeEventsInOrderWithTimestamps) {
  gpiod_line* line = gpiod_chip_get_line(chip_, 2);
  ASSERT_EQ(gpiod_line_request_both_edges_events(line, "hapticd"), 0) << std::strerror(errno);
  EXPECT_EQ(gpiod_line_get_value(line), 0);
  bed_.drive_input(2, true, 1'000'000'123);
  bed_.drive_input(2, false, 2'000'000'456);
  const timespec timeout{1, 0};
  ASSERT_EQ(gpiod_line_event_wait(line, &timeout), 1);
  gpiod_line_event events[4];
  ASSERT_EQ(gpiod_line_event_read_multiple(line, events, 4), 2);
  EXPECT_EQ(events[0].event_type, GPIOD_LINE_EVENT_RISING_EDGE);
  EXPECT_EQ(events[0].ts.tv_sec, 1);
  EXPECT_EQ(events[0].ts.tv_nsec, 123);
  EXPECT_EQ(events[1].event_type, GPIOD_LINE_EVENT_FALLING_EDGE);
  EXPECT_EQ(events[1].ts.tv_nsec, 456);
  EXPECT_EQ(gpiod_line_get_value(line), 0);
  // Nothing left: the wait times out.
  const timespec short_timeout{0, 20'000'000};
  EXPECT_EQ(gpiod_line_event_wait(line, &short_timeout), 0);
}

TEST_F(LibgpiodTestbed, KernelQueueHoldsSixteenEventsAndDropsTheRest) {
  gpiod_line* line = gpiod_chip_get_line(chip_, 3);
  ASSERT_EQ(gpiod_line_request_both_edges_events(line, "hapticd"), 0);
  for (int i = 0; i < 20; ++i) bed_.drive_input(3, i % 2 == 0, static_cast<std::uint64_t>(i + 1));
  EXPECT_EQ(bed_.dropped_events(), 4u);
  gpiod_line_event events[16];
  ASSERT_EQ(gpiod_line_event_read_multiple(line, events, 16), 16);
  EXPECT_EQ(events[15].ts.tv_nsec, 16);
}

TEST_F(LibgpiodTestbed, NonBlockingReadOfAnEmptyQueueIsEagain) {
  gpiod_line* line = gpiod_chip_get_line(chip_, 4);
  ASSERT_EQ(gpiod_line_request_rising_edge_events(line, "hapticd"), 0);
  const int fd = gpiod_line_event_get_fd(line);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK), 0);
  gpiod_line_event event;
  errno = 0;
  EXPECT_EQ(gpiod_line_event_read(line, &event), -1);
  EXPECT_EQ(errno, EAGAIN);
  bed_.drive_input(4, true, 7);
  bed_.drive_input(4, false, 8);  // rising edges only: not queued
  ASSERT_EQ(gpiod_line_event_read(line, &event), 0);
  EXPECT_EQ(event.event_type, GPIOD_LINE_EVENT_RISING_EDGE);
  EXPECT_EQ(gpiod_line_event_read(line, &event), -1);
  EXPECT_EQ(errno, EAGAIN);
}

TEST_F(LibgpiodTestbed, BlockingReadWaitsForTheNextEvent) {
  gpiod_line* line = gpiod_chip_get_line(chip_, 4);
  ASSERT_EQ(gpiod_line_request_both_edges_events(line, "hapticd"), 0);
  std::thread driver([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(30));
    bed_.drive_input(4, true, 99);
  });
  gpiod_line_event event;
  EXPECT_EQ(gpiod_line_event_read(line, &event), 0);
  EXPECT_EQ(event.ts.tv_nsec, 99);
  driver.join();
}

}  // namespace
}  // namespace hapticd::drivers::gpio_pwm::sim::libgpiod_testbed_test
