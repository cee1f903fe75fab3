// The skeleton driver: its codec byte by byte against README.md's table,
// the conformance suite every driver passes against the plant simulator
// (skeleton_peer.*), and what the exchange does with the position and a
// silent peer.

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <numbers>

#include "drivers/skeleton/skeleton_device.hpp"
#include "drivers/skeleton/skeleton_frame.hpp"
#include "skeleton_peer.hpp"
#include "tests/drivers/conformance/device_conformance.hpp"

namespace {

using namespace hapticd::drivers::skeleton;
using hapticd::testing::BadParameters;
using hapticd::testing::ParameterTable;
using hapticd::testing::SkeletonPeer;

TEST(SkeletonFrame, RequestBytesAsTheTableSays) {
  const Frame f = encode({0x1234, true, true, -2});
  EXPECT_EQ(f, (Frame{0x34, 0x12, 0x03, 0x00, 0xFE, 0xFF, 0xFF, 0xFF}));
  EXPECT_EQ(encode({7, false, false, 0x01020304}), (Frame{0x07, 0x00, 0x00, 0x00, 0x04, 0x03, 0x02, 0x01}));
}

TEST(SkeletonFrame, ReplyBytesAsTheTableSays) {
  const std::array<std::uint8_t, 8> bytes{0x08, 0x00, 0x03, 0x21, 0xF0, 0xFF, 0xFF, 0xFF};
  const auto r = decode_reply(bytes);
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->sequence, 8);
  EXPECT_TRUE(r->enabled);
  EXPECT_TRUE(r->faulted);
  EXPECT_EQ(r->fault_code, 0x21);
  EXPECT_EQ(r->position, -16);
}

TEST(SkeletonFrame, WrongSizesAndReservedBitsAreRefused) {
  const std::array<std::uint8_t, 9> long_one{};
  EXPECT_FALSE(decode_reply(std::span<const std::uint8_t>(long_one.data(), 7)).has_value());
  EXPECT_FALSE(decode_reply(long_one).has_value());
  const std::array<std::uint8_t, 8> reserved{0, 0, 0x04, 0, 0, 0, 0, 0};
  EXPECT_FALSE(decode_reply(reserved).has_value());
}

hapticd::drivers::simulation::PlantConfig wheel() {
  auto c = hapticd::drivers::simulation::PlantConfig::defaults(hapticd::drivers::Motion::rotary);
  c.period_s = 1e-3;
  return c;
}

struct SkeletonConformance {
  static constexpr const char* driver = "skeleton";
  SkeletonPeer peer{wheel(), 1e-3, 4096.0};
  ParameterTable parameters() {
    // The suite runs read()/write() back to back; the peer's thread may wait
    // for a CPU on a loaded machine: a timeout far above its reply time.
    return {{"socket", peer.path()}, {"mass", 0.01}, {"response_timeout", std::string("20ms")}};
  }
  ParameterTable with(const std::string& key, hapticd::drivers::ParameterValue value) {
    ParameterTable t = parameters();
    t[key] = std::move(value);
    return t;
  }
  double period_s() { return 0.05; }
  void inject_device_fault(hapticd::drivers::Device&) { peer.inject_fault(0x21); }
  double observed_output(hapticd::drivers::Device&) { return peer.applied_force(); }
  std::vector<BadParameters> bad_parameters() {
    ParameterTable no_mass = parameters();
    no_mass.erase("mass");
    return {{with("socket", std::string("")), "socket"},
            {with("socket", std::string("/nonexistent/peer.sock")), "socket"},
            {with("response_timeout", std::string("60ms")), "response_timeout"},  // over the 50 ms period
            {with("force_per_count", 0.0), "force_per_count"},
            {no_mass, "mass"}};
  }
};

TEST(SkeletonDevice, ThePositionComesInSiAndTheCommandGoesOutInCounts) {
  SkeletonConformance rig;
  auto device = hapticd::testing::make_device("skeleton", rig.parameters());
  device->configure({0.05});
  device->enable();
  hapticd::drivers::Reading r;
  ASSERT_EQ(device->write(0.25), hapticd::drivers::IoResult::ok);  // 250 counts of 1 mN m
  ASSERT_EQ(device->read(r), hapticd::drivers::IoResult::ok);      // sends it; the plant applies it
  EXPECT_DOUBLE_EQ(rig.peer.applied_force(), 0.25);
  for (int i = 0; i < 200; ++i) {
    ASSERT_EQ(device->read(r), hapticd::drivers::IoResult::ok);
    ASSERT_EQ(device->write(0.25), hapticd::drivers::IoResult::ok);
  }
  const double count = 2.0 * std::numbers::pi / 4096.0;
  EXPECT_GT(r.position, 100 * count) << "0.25 N m turned the wheel";
  EXPECT_NEAR(std::remainder(r.position, count), 0.0, 1e-12) << "whole counts, in rad";
  device->close();
}

TEST(SkeletonDevice, APeerThatGoesAwayLatchesAFaultWithTheReason) {
  auto rig = std::make_unique<SkeletonConformance>();
  auto device = hapticd::testing::make_device(
      "skeleton", {{"socket", rig->peer.path()}, {"mass", 0.01}, {"response_timeout", std::string("2ms")}});
  device->configure({0.05});
  device->enable();
  rig.reset();  // the peer's process is gone: its socket closes
  hapticd::drivers::Reading r;
  EXPECT_EQ(device->read(r), hapticd::drivers::IoResult::fault);
  EXPECT_EQ(device->status().state, hapticd::drivers::DeviceState::fault);
  EXPECT_NE(device->status().fault_reason.find("the link to the peer is lost"), std::string::npos)
      << device->status().fault_reason;
  device->close();
}

}  // namespace

namespace hapticd::testing::skeleton_test {
INSTANTIATE_TYPED_TEST_SUITE_P(Skeleton, DeviceConformance, SkeletonConformance);
}  // namespace hapticd::testing::skeleton_test
