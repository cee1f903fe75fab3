#pragma once
// A simulated board on an emulated USB bus, for tests that run libusb's
// real Linux code path (see sim/usb_hid/umockdev_board.hpp).

#include <gtest/gtest.h>

#include <memory>

#include "sim/usb_hid/simulated_board.hpp"
#include "sim/usb_hid/umockdev_board.hpp"

namespace hapticd::drivers::usb_hid::testing {

/// A plant whose position moves by `gain` x force each period: simple
/// enough that a test can predict every count, and it moves.
class RampPlant final : public sim::BoardPlant {
 public:
  explicit RampPlant(double gain) : gain_(gain) {}
  IoResult sense(double& position) noexcept override {
    position = position_;
    return IoResult::ok;
  }
  IoResult step(double force) noexcept override {
    position_ += gain_ * force;
    forces_.push_back(force);
    return IoResult::ok;
  }
  double position() const { return position_; }
  const std::vector<double>& forces() const { return forces_; }

 private:
  double gain_;
  double position_ = 0.0;
  std::vector<double> forces_;
};

class EmulatedBoardTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // The build links libumockdev-preload (--no-as-needed): not in the
    // process at run time is a broken install, never a reason to skip.
    if (!sim::UmockdevUsbBoard::preload_active())
      GTEST_FAIL() << "libumockdev-preload is not loaded in this process, though the build links it: "
                      "a broken install (apt-get install libumockdev0)";
    make_board(sim::EmulatedUsbIdentity{});
  }
  void make_board(const sim::EmulatedUsbIdentity& identity,
                  sim::BoardClock clock = sim::BoardClock::deterministic) {
    testbed.reset();
    board.reset();
    plant = std::make_unique<RampPlant>(scaling.position_per_count / scaling.command_full_scale * 1000.0);
    board = std::make_unique<sim::SimulatedBoard>(scaling, *plant, clock);
    testbed = std::make_unique<sim::UmockdevUsbBoard>(identity, *board);
  }
  void TearDown() override {
    testbed.reset();
    board.reset();
  }

  sim::BoardScaling scaling{};
  std::unique_ptr<RampPlant> plant;
  std::unique_ptr<sim::SimulatedBoard> board;
  std::unique_ptr<sim::UmockdevUsbBoard> testbed;
};

}  // namespace hapticd::drivers::usb_hid::testing
