// The period check against the endpoint descriptor (USB 2.0 9.6.6 Table
// 9-13: full/low speed bInterval in 1 ms frames, high speed and SuperSpeed
// 2^(bInterval-1) x 125 us microframes).

#include <gtest/gtest.h>

#include <string>

#include "drivers/usb_hid/link_budget.hpp"

namespace hapticd::drivers::usb_hid::link_budget_test {
namespace {

TEST(PollingInterval, PerBusSpeed) {
  EXPECT_DOUBLE_EQ(*interrupt_interval_s(UsbSpeed::full, 1), 1e-3);
  EXPECT_DOUBLE_EQ(*interrupt_interval_s(UsbSpeed::full, 10), 10e-3);
  EXPECT_DOUBLE_EQ(*interrupt_interval_s(UsbSpeed::full, 255), 255e-3);
  EXPECT_FALSE(interrupt_interval_s(UsbSpeed::full, 0));
  EXPECT_DOUBLE_EQ(*interrupt_interval_s(UsbSpeed::low, 10), 10e-3);
  EXPECT_FALSE(interrupt_interval_s(UsbSpeed::low, 9)) << "USB 2.0: low speed bInterval 10..255";
  EXPECT_DOUBLE_EQ(*interrupt_interval_s(UsbSpeed::high, 1), 125e-6);
  EXPECT_DOUBLE_EQ(*interrupt_interval_s(UsbSpeed::high, 2), 250e-6);
  EXPECT_DOUBLE_EQ(*interrupt_interval_s(UsbSpeed::high, 4), 1e-3);
  EXPECT_DOUBLE_EQ(*interrupt_interval_s(UsbSpeed::high, 16), 4.096);
  EXPECT_FALSE(interrupt_interval_s(UsbSpeed::high, 0));
  EXPECT_FALSE(interrupt_interval_s(UsbSpeed::high, 17));
  EXPECT_DOUBLE_EQ(*interrupt_interval_s(UsbSpeed::super, 3), 500e-6);
  EXPECT_FALSE(interrupt_interval_s(UsbSpeed::unknown, 1));
}

EndpointInfo endpoint(UsbSpeed speed, std::uint8_t b_interval, std::uint16_t max_packet = 64,
                      std::uint8_t address = 0x81) {
  EndpointInfo ep;
  ep.address = address;
  ep.max_packet_size = max_packet;
  ep.b_interval = b_interval;
  ep.speed = speed;
  return ep;
}

TEST(CheckEndpoint, AcceptsWhatCarriesOneReportPerPeriod) {
  EXPECT_EQ(check_endpoint(endpoint(UsbSpeed::full, 1), 1e-3, 16), "");
  EXPECT_EQ(check_endpoint(endpoint(UsbSpeed::full, 1), 10e-3, 16), "");
  EXPECT_EQ(check_endpoint(endpoint(UsbSpeed::full, 2), 2e-3, 16), "");
  EXPECT_EQ(check_endpoint(endpoint(UsbSpeed::high, 1), 125e-6, 16), "");
  EXPECT_EQ(check_endpoint(endpoint(UsbSpeed::high, 2), 250e-6, 16), "");
  EXPECT_EQ(check_endpoint(endpoint(UsbSpeed::high, 4), 1e-3, 64), "");
}

TEST(CheckEndpoint, RefusesWithTheFigure) {
  EXPECT_EQ(
      check_endpoint(endpoint(UsbSpeed::full, 1), 500e-6, 16),
      "IN endpoint 0x81 is polled every 1 ms (full speed (12 Mbit/s), bInterval 1): a 500 us period needs "
      "one report per period; a full-speed board is polled at most every 1 ms (bInterval 1)");
  EXPECT_EQ(check_endpoint(endpoint(UsbSpeed::high, 4, 64, 0x02), 250e-6, 8),
            "OUT endpoint 0x02 is polled every 1 ms (high speed (480 Mbit/s), bInterval 4): a 250 us period "
            "needs one report per period; a high-speed board is polled at most every 125 us (bInterval 1)");
  EXPECT_EQ(check_endpoint(endpoint(UsbSpeed::full, 2), 1e-3, 16).substr(0, 37),
            "IN endpoint 0x81 is polled every 2 ms");
  EXPECT_EQ(check_endpoint(endpoint(UsbSpeed::low, 10, 8), 10e-3, 16),
            "IN endpoint 0x81 carries 8 bytes per interval (wMaxPacketSize 8, low speed (1.5 Mbit/s)): the "
            "report is 16 bytes");
  EXPECT_NE(check_endpoint(endpoint(UsbSpeed::high, 1), 100e-6, 16).find("is polled every 125 us"),
            std::string::npos)
      << "no USB endpoint carries a 100 us period";
  EXPECT_NE(check_endpoint(endpoint(UsbSpeed::unknown, 1), 1e-3, 16).find("bus speed is unknown"),
            std::string::npos);
  EXPECT_NE(check_endpoint(endpoint(UsbSpeed::high, 0), 1e-3, 16).find("not valid at high speed"),
            std::string::npos);
}

TEST(CheckEndpoint, HighBandwidthCountsExtraTransactions) {
  EndpointInfo ep = endpoint(UsbSpeed::high, 1, 8);
  EXPECT_NE(check_endpoint(ep, 1e-3, 16), "");
  ep.extra_transactions = 1;
  EXPECT_EQ(bytes_per_interval(ep), 16U);
  EXPECT_EQ(check_endpoint(ep, 1e-3, 16), "");
}

TEST(LinkDelay, InPlusOutIntervalInPeriods) {
  EXPECT_EQ(link_delay_periods(1e-3, 1e-3, 1e-3), 2);  // full speed at 1 ms
  EXPECT_EQ(link_delay_periods(1e-3, 1e-3, 2e-3), 1);
  EXPECT_EQ(link_delay_periods(125e-6, 125e-6, 1e-3), 1);  // high speed at 1 ms
  EXPECT_EQ(link_delay_periods(125e-6, 125e-6, 125e-6), 2);
  EXPECT_EQ(link_delay_periods(1e-3, 1e-3, 0.0), 0);
}

}  // namespace
}  // namespace hapticd::drivers::usb_hid::link_budget_test
