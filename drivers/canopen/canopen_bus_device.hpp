#pragma once
/// \file
/// The canopen driver's hooks for several CiA 402 drives on one bus, one per
/// axis (`node_ids = "1,2"`; README.md, "Several drives on one bus"). One
/// socket, one SYNC per period for all; each node has its own setup (the
/// same as one drive's, drive_setup.hpp), its own RPDO1/TPDO1 (the
/// predefined connection set: 0x200 + n, 0x180 + n), its EMCY (0x80 + n) and
/// heartbeat (0x700 + n) watched by its own CyclicExchange. hapticd's
/// heartbeat (0x700 + master) goes out once for all.
///
/// Per period: read_axes() drains the socket once and hands each frame to
/// every node's exchange (each takes its own COB-IDs; an error frame, the
/// bus', reaches all); write_axes() sends every node's RPDO1, then one SYNC,
/// then the heartbeat when due. A fault on any node (its EMCY, its
/// statusword, its TPDO or heartbeat missing ...) zeroes every axis in the
/// period it is seen: read_axes() says fault and write_axes() sends torque 0
/// with halt to every node until the fault is cleared. health() names the
/// axis and the node. `fault clear` resets the faulted nodes (CiA 402 fault
/// reset) and brings every node back to Operation Enabled.
///
/// The bus budget for all nodes (one SYNC, every node's PDOs, one frame of
/// other traffic) is checked first in configure(), before the bus is
/// touched, and refused with the bits per period and the bit rate.
///
/// With homing = "cia402" every node homes before the loop, all in the same
/// periods, each with its own method and offset when axis_homing_method,
/// axis_home_offset are given (homing.hpp); each back in cyclic synchronous
/// torque after; a node that fails names its axis.
///
/// Commissioning: device.sdo.read and device.sdo.write with `node` reach any
/// object of that node while the loop runs (the request goes out on the
/// socket, the answer comes back through the loop's read_axes() and that
/// node's SPSC ring), with one drive's rules: what scales or bounds the
/// torque is refused while enabled, and 0x6076 is read back after every
/// write; a new unit reaches that node's exchange through its own ring.
///
/// Threads as in canopen_device.hpp.

#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "drivers/canopen/301/bus_budget.hpp"
#include "drivers/canopen/can_socket.hpp"
#include "drivers/canopen/canopen_config.hpp"
#include "drivers/canopen/commissioning.hpp"
#include "drivers/canopen/cyclic_exchange.hpp"
#include "drivers/canopen/drive_setup.hpp"
#include "drivers/canopen/exchange_status.hpp"
#include "drivers/canopen/homing.hpp"
#include "drivers/device_hooks.hpp"

namespace hapticd::drivers::canopen {

/// The bus budget of several drives in one period: one SYNC, each node's
/// RPDO1 and TPDO1 (+ TPDO2), one frame of other traffic; the summary names
/// the nodes. Throws std::invalid_argument as check_bus_budget.
cia301::BusBudget bus_budget_for_nodes(std::span<const CyclicMapping> mappings,
                                       std::span<const std::uint8_t> nodes, double period_s,
                                       std::uint32_t bitrate);

class CanopenBusDevice final : public DeviceHooks {
 public:
  /// Validates the config (throws ConfigError naming the key); node_ids
  /// names 2 or more drives.
  explicit CanopenBusDevice(CanopenConfig config);
  ~CanopenBusDevice() override;
  CanopenBusDevice(const CanopenBusDevice&) = delete;
  CanopenBusDevice& operator=(const CanopenBusDevice&) = delete;

  /// Bus budget, socket, every node's setup, NMT start, one SYNC and every
  /// node's first TPDO1. Throws SetupError naming the key, or StopRequested.
  void configure(const LoopContext& loop) override;
  /// Every node to Operation Enabled with zero torque. Throws SetupError naming the node.
  void enable() override;
  /// Resets the faulted nodes and enables them again; returns what was
  /// cleared. Throws SetupError if a node stays in fault.
  std::string clear_fault() override;
  void disable() noexcept override;
  /// Undoes every node's dead-man (drive_setup.hpp), then releases the socket.
  void close() noexcept override;

  IoResult read(Reading& out) noexcept override;   ///< error: this device has several axes
  IoResult write(double force) noexcept override;  ///< error: this device has several axes
  int axes() const noexcept override { return static_cast<int>(nodes_.size()); }
  IoResult read_axes(std::span<Reading> out) noexcept override;
  IoResult write_axes(std::span<const double> forces) noexcept override;

  DeviceModel model() const override;
  DeviceHealth health() const override;
  /// Every node's homing, when asked for: the method, the longest node's time, axis 1's home.
  std::optional<DeviceHoming> homing() const override { return homing_; }
  /// "interface unix:/x, node 1 (vendor ..., serial ...), node 2 (...)".
  std::string identity() const override;
  /// device.sdo.read (index, sub, node [, type]).
  std::vector<DeviceMethod> methods() override;

  /// Reads `address` of node `node` by SDO while the loop runs (non-RT).
  /// Throws std::invalid_argument (no such node, the loop not running) or SdoError.
  SdoAccess sdo_read(std::uint8_t node, cia301::ObjectAddress address, std::optional<cia301::DataType> type);
  /// Writes it, as one drive's sdo_write (canopen_device.hpp): while enabled
  /// what scales or bounds the torque is refused; 0x6076 is read back after
  /// every write and a new unit rescales that node's axis from the next
  /// period (while enabled: a fault that zeroes every axis). Throws as
  /// sdo_read, or SetupError (0x6076 unreadable).
  SdoAccess sdo_write(std::uint8_t node, cia301::ObjectAddress address, std::int64_t value,
                      std::optional<cia301::DataType> type);

  // ---- observation, from configure() on (any non-RT thread) ----
  /// What the loop published last of axis `axis` (0-based).
  ExchangeStatus exchange_status(std::size_t axis) const;
  const cia301::BusBudget& budget() const noexcept { return budget_; }
  const CanopenConfig& config() const noexcept { return config_; }

 private:
  struct Node;
  void prime();
  template <class Done>
  bool run_periods(Done&& done, std::uint64_t max_periods);
  bool loop_running() const;
  void await_reset_by_loop() const;
  bool all(bool (CyclicExchange::*test)() const noexcept) const;
  bool any(bool (CyclicExchange::*test)() const noexcept) const;
  /// "axis 2 (node 2): <the node's fault in words>" for the first faulted axis, "" if none.
  std::string fault_words() const;
  void run_homing();
  /// "CiA 402 homing method 17 (...) on nodes 1, 2", or each node's method when they differ.
  std::string homing_words() const;
  /// The key a homing failure blames: axis_homing_method (axis_home_offset) when that list gave the value.
  std::string homing_key(const std::string& key) const;
  void drive_homing(std::vector<HomingSequence>& sequences, double& home);
  template <class Use>
  void with_each_node_sdo(Use&& use);
  std::chrono::microseconds sdo_timeout() const;  ///< the config's, per transfer
  /// The 0-based axis of a node-ID; throws std::invalid_argument naming node_ids.
  std::size_t axis_of_node(std::uint8_t node_id) const;
  /// `use(node, sdo)` over that node's ring while the loop runs; throws std::invalid_argument if it does not.
  template <class Use>
  auto with_node_sdo(std::size_t axis, Use&& use);
  std::string recheck_torque_unit(std::size_t axis, Node& node, SdoClient& sdo, bool fault_if_changed);
  void apply_torque_units() noexcept;  ///< RT: takes what recheck_torque_unit() handed over
  void drain_socket() noexcept;        ///< RT
  void publish_all() noexcept;         ///< RT

  const CanopenConfig config_;
  StopToken stop_;
  double period_s_ = 0.0;
  CanSocket socket_;
  cia301::BusBudget budget_;
  std::vector<std::unique_ptr<Node>> nodes_;
  bool configured_ = false;  ///< every node set up and primed
  std::optional<DeviceHoming> homing_;
  std::atomic<bool> clear_requested_{false};
  std::atomic<bool> disable_requested_{false};
  std::atomic<bool> enabled_{false};  ///< enable() done, not disabled since (guards the commissioning writes)
  std::atomic<std::uint64_t> reads_{0};
  std::atomic<std::uint64_t> publications_{0};
  std::mutex sdo_mutex_;  ///< one commissioning transfer at a time (non-RT)
};

}  // namespace hapticd::drivers::canopen
