// The canopen driver through the conformance suite every Device passes,
// built through the registry as the daemon builds it, against the simulated
// CiA 402 drive on the unix seam (its bus loop in a thread).

#include <unistd.h>

#include <atomic>
#include <filesystem>
#include <thread>

#include "sim/canopen/drive_bus.hpp"
#include "sim/canopen/simulated_drive.hpp"
#include "tests/drivers/conformance/device_conformance.hpp"

namespace {

using hapticd::testing::BadParameters;
using hapticd::testing::ParameterTable;
namespace sim = hapticd::drivers::canopen::sim;

class WheelPlant final : public sim::DrivePlant {
 public:
  double position() const override { return x_; }
  double velocity() const override { return v_; }
  void step(double force) override {
    const double a = force / 0.01;
    x_ += v_ * 1e-3 + 0.5 * a * 1e-6;
    v_ += a * 1e-3;
  }

 private:
  double x_ = 0.0, v_ = 0.0;
};

std::string bus_path() {
  static std::atomic<int> n{0};
  return (std::filesystem::temp_directory_path() /
          ("hapticd-canopen-conformance-" + std::to_string(::getpid()) + "-" + std::to_string(n++)))
      .string();
}

struct CanopenConformance {
  static constexpr const char* driver = "canopen";

  CanopenConformance() : path(bus_path()), drive(settings(), plant), bus(path, drive) {
    thread = std::thread([this] { bus.run(stop); });
  }
  ~CanopenConformance() {
    stop = true;
    thread.join();
  }
  static sim::DriveSettings settings() {
    sim::DriveSettings s;
    s.node_id = 5;
    s.rated_torque_mnm = 500;
    return s;
  }
  ParameterTable parameters() {
    // The suite runs read()/write() back to back, far faster than 1 ms, and
    // the drive's thread may not run at all meanwhile on a loaded machine:
    // the timeouts counted in periods are set wide so only real faults count.
    return {{"interface", "unix:" + path},
            {"node_id", 5.0},
            {"mass", 0.01},
            {"counts_per_unit", 16384.0},
            {"tpdo_timeout_periods", 100000.0},
            {"heartbeat_timeout", 10.0},
            {"sdo_timeout", 2.0}};  // the drive's thread went 500 ms unscheduled at load 11
  }
  ParameterTable with(const std::string& key, hapticd::drivers::ParameterValue value) {
    ParameterTable t = parameters();
    t[key] = std::move(value);
    return t;
  }
  double period_s() { return 1e-3; }
  void inject_device_fault(hapticd::drivers::Device&) { bus.command("fault 0x2310"); }
  double observed_output(hapticd::drivers::Device&) {
    bus.settle();  // the frames written so far have reached the drive
    return bus.applied_force();
  }
  std::vector<BadParameters> bad_parameters() {
    ParameterTable no_mass = parameters();
    no_mass.erase("mass");
    return {{with("node_id", 0.0), "node_id"},
            {with("node_id", 9.0), "node_id"},  // nobody answers at node 9
            {with("interface", std::string("unix:/nonexistent/bus")), "interface"},
            {with("bitrate", 125000.0), "bitrate"},  // 3.2 ms of frames for a 1 ms period
            {with("master_node_id", 5.0), "master_node_id"},
            {with("heartbeat_timeout", 0.01), "heartbeat_timeout"},  // below the 20 ms period
            {with("heartbeat_period", 0.0205), "heartbeat_period"},  // 0x1017 is whole ms
            {no_mass, "mass"}};
  }

  std::string path;
  WheelPlant plant;
  sim::SimulatedDrive drive;
  sim::DriveBus bus;
  std::atomic<bool> stop{false};
  std::thread thread;
};

}  // namespace

namespace hapticd::testing::canopen_conformance_test {
INSTANTIATE_TYPED_TEST_SUITE_P(Canopen, DeviceConformance, CanopenConformance);
}  // namespace hapticd::testing::canopen_conformance_test
