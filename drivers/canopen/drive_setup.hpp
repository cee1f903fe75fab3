#pragma once
/// \file
/// Configuring a CiA 402 drive for cyclic synchronous torque, in
/// pre-operational, over SDO (non-RT, before the loop runs):
///   1. NMT enter pre-operational; 0x1000 must say CiA 402; identity 0x1018
///   2. power stage off (0x6040 = Disable Voltage), 0x6071 = 0
///   3. 0x6502 must offer cyclic synchronous torque (if the drive has 0x6502);
///      0x6060 = 10, confirmed by reading 0x6061 back
///   4. 0x6076 rated torque (the config's rated_torque only for a drive
///      without 0x6076, and refused if it differs from the drive's); 0x60C2 = the period
///   5. PDO mapping the standard way (301/pdo.hpp): RPDO1 = 0x6040 + 0x6071,
///      TPDO1 = 0x6041 + 0x6064, TPDO2 = 0x606C only if asked; the other
///      PDOs made not valid; transmission type 1 (every SYNC)
///   6. dead-man: 0x6007 = 1 (a lost master is a fault), 0x1017 = the
///      drive's heartbeat period, 0x1016:1 = hapticd's node and timeout
/// Objects a drive may lack and the driver can do without (0x6502, 0x60C2,
/// 0x6007, 0x1018:2..4, PDOs 2..4) are noted, not fatal.

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "drivers/canopen/301/bus_budget.hpp"
#include "drivers/canopen/301/pdo.hpp"
#include "drivers/canopen/402/objects.hpp"
#include "drivers/canopen/402/state_machine.hpp"
#include "drivers/canopen/sdo_client.hpp"
#include "drivers/device_hooks.hpp"

namespace hapticd::drivers::canopen {

/// The cyclic PDOs: RPDO1 controlword + target torque; TPDO1 statusword +
/// position; TPDO2 velocity when asked for. Default COB-IDs of the node.
struct CyclicMapping {
  cia301::PdoLayout rpdo;
  std::uint32_t rpdo_id = 0;
  cia301::PdoLayout tpdo_position;
  std::uint32_t tpdo_position_id = 0;
  std::optional<cia301::PdoLayout> tpdo_velocity;
  std::uint32_t tpdo_velocity_id = 0;
};
CyclicMapping standard_mapping(std::uint8_t node, bool velocity);
/// The frames of one period for the bus budget: SYNC, RPDO1, TPDO1 (+ TPDO2).
std::vector<cia301::CyclicFrame> cyclic_frames(const CyclicMapping& mapping);

struct SetupOptions {
  std::uint8_t node = 1;
  std::uint8_t master_node = 127;
  double period_s = 1e-3;
  std::uint16_t heartbeat_period_ms = 20;    ///< 0x1017 on the drive
  std::uint16_t heartbeat_timeout_ms = 100;  ///< 0x1016:1 on the drive
  std::uint32_t rated_torque_mnm = 0;        ///< 0: read 0x6076
  bool velocity = false;
};

struct DriveIdentity {
  std::uint32_t device_type = 0;
  std::uint32_t vendor_id = 0, product_code = 0, revision = 0, serial = 0;
};

struct SetupResult {
  DriveIdentity identity;
  std::uint32_t rated_torque_mnm = 0;    ///< the unit of 0x6071 (per mille of it), mN m
  bool rated_torque_from_drive = false;  ///< the drive has 0x6076 (read back at every enable)
  cia402::DriveState state = cia402::DriveState::not_ready_to_switch_on;
  CyclicMapping mapping;
  std::vector<std::string> notes;  ///< what the drive lacks that the driver did without
};

/// One line for a setup that cannot go on; key: the config parameter to
/// blame ("" if none). The framework's DeviceError: it reaches the daemon as
/// it is thrown.
using SetupError = DeviceError;

/// 0x6076 motor rated torque (mN m) as the drive has it now; nullopt if it
/// has no 0x6076. Throws SdoError for any other failure.
std::optional<std::uint32_t> read_rated_torque(SdoClient& sdo);
/// The unit of 0x6071 target torque (CiA 402: per mille of 0x6076): the
/// drive's 0x6076, which the config's rated_torque (`config_mnm`, 0 if not
/// given) must equal, since the drive scales by its own; the config's only
/// for a drive without 0x6076. Throws SetupError (key rated_torque).
std::uint32_t torque_unit(std::optional<std::uint32_t> drive_mnm, std::uint32_t config_mnm,
                          std::uint8_t node);

/// 0x6060 = mode, confirmed by reading 0x6061 back (a few reads); a drive
/// that shows another mode is a SetupError blaming `key`, an SDO failure
/// one blaming `sdo_key`.
void select_mode(SdoClient& sdo, cia402::Mode mode, const std::string& key, const std::string& sdo_key = "");

/// Runs the steps above. Throws SetupError.
SetupResult setup_drive(SdoClient& sdo, FrameLink& link, const SetupOptions& options);

/// The setup step 6 undone on the way out: hapticd's heartbeat stops, so the
/// drive stops watching it (0x1016:1 = 0) and goes pre-operational.
void release_drive(SdoClient& sdo, FrameLink& link, std::uint8_t node) noexcept;

}  // namespace hapticd::drivers::canopen
