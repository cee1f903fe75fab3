#pragma once
// hapticd-devsim canopen (the simulated CiA 402 drive) as its own process,
// for the canopen end-to-end tests: commands on its stdin, replies in its log.

#include <sys/types.h>

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "tests/e2e/support.hpp"

namespace hapticd::e2e {

/// The loopback's rigid wheel, J = 0.01 kg m^2 (the drive's default plant).
inline const std::string rigid_wheel_plant = "damping=0.002 max_force=1.2";

std::filesystem::path devsim_binary();

class SimulatedDrive {
 public:
  /// Starts the drive on dir/bus.sock and waits until it listens (throws
  /// after 10 s). plant: --plant, as the loopback's keys; extra: more options
  /// (--rated-torque 20, ...); fifo_priority > 0: the drive's process runs
  /// SCHED_FIFO at it, as a drive is its own hardware (below hapticd's loop,
  /// 80; a host that refuses it runs the drive as before, said in its log).
  SimulatedDrive(const TempDir& dir, const std::string& hand, const std::string& plant = rigid_wheel_plant,
                 const std::vector<std::string>& extra = {}, int fifo_priority = 0);
  /// One of several drives: node `node` joins the bus at `bus_interface`
  /// (hapticd-devsim canopen --connect ... --node-id N), its log dir/devsim-nodeN.log.
  static std::unique_ptr<SimulatedDrive> member(const TempDir& dir, const std::string& bus_interface,
                                                int node, const std::string& hand, const std::string& plant,
                                                const std::vector<std::string>& extra = {},
                                                int fifo_priority = 0);
  ~SimulatedDrive();
  SimulatedDrive(const SimulatedDrive&) = delete;
  SimulatedDrive& operator=(const SimulatedDrive&) = delete;

  std::string interface() const { return "unix:" + bus_.string(); }
  std::string log() const;
  /// Sends one command line and returns its reply line ("<no reply>" after 5 s).
  std::string command(const std::string& line);
  void kill_now();

 private:
  struct Spawn {
    std::vector<std::string> args;
    std::filesystem::path log;
    std::string ready;  ///< the log line that says it runs
    int fifo_priority = 0;
  };
  SimulatedDrive(std::filesystem::path bus, const Spawn& spawn);
  std::vector<std::string> replies() const;
  std::filesystem::path bus_;
  std::filesystem::path log_;
  pid_t pid_ = -1;
  int commands_ = -1;
};

/// hapticd-devsim canbus (the simulated bus several drives and hapticd join)
/// as its own process on dir/bus.sock; stopped at destruction.
class SimulatedCanBus {
 public:
  explicit SimulatedCanBus(const TempDir& dir, int fifo_priority = 0);
  ~SimulatedCanBus();
  SimulatedCanBus(const SimulatedCanBus&) = delete;
  SimulatedCanBus& operator=(const SimulatedCanBus&) = delete;
  std::string interface() const { return "unix:" + bus_.string(); }
  std::string log() const;

 private:
  std::filesystem::path bus_;
  std::filesystem::path log_;
  pid_t pid_ = -1;
};

}  // namespace hapticd::e2e
