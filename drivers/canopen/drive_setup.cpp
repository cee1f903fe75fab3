#include "drivers/canopen/drive_setup.hpp"

#include <cstdio>

#include "drivers/canopen/301/cob_id.hpp"
#include "drivers/canopen/301/nmt.hpp"
#include "drivers/canopen/301/object_dictionary.hpp"
#include "drivers/canopen/402/drive_errors.hpp"
#include "drivers/canopen/402/objects.hpp"
#include "world/text.hpp"

namespace hapticd::drivers::canopen {

using cia301::MappingEntry;
using cia301::ObjectAddress;
using cia301::PdoDirection;
namespace obj301 = cia301::object;
namespace obj402 = cia402::object;
using cia402::describe_error_code;

namespace {

constexpr int pdo_count = 4;
constexpr std::uint16_t profile_402 = 402;
constexpr int mode_confirm_reads = 5;

std::string node_name(std::uint8_t node) { return "node " + std::to_string(node); }

/// Runs one step; an SDO failure becomes a SetupError blaming `key`. A
/// missing object is returned as false when `optional`.
template <class Step>
bool step(Step&& run, const std::string& key, bool optional = false) {
  try {
    run();
    return true;
  } catch (const SdoError& e) {
    if (optional && e.object_missing()) return false;
    throw SetupError(e.what(), key);
  }
}

void configure_pdos(SdoClient& sdo, const SetupOptions& options, const CyclicMapping& m,
                    SetupResult& result) {
  auto write_all = [&](const std::vector<cia301::SdoWrite>& writes, bool optional) {
    bool present = true;
    for (const cia301::SdoWrite& w : writes) {
      present = step([&] { sdo.write(w.address, w.value, w.size); }, "", optional);
      if (!present) break;
    }
    return present;
  };
  for (int p = 1; p <= pdo_count; ++p) {
    const std::uint32_t rx_id = cia301::default_rpdo_id(p, options.node);
    if (p == 1) {
      write_all(cia301::pdo_configuration_sequence({PdoDirection::receive, 1, m.rpdo_id, 1, m.rpdo}), false);
    } else if (!write_all(cia301::pdo_configuration_sequence({PdoDirection::receive, p, rx_id, 1, {}}),
                          true)) {
      result.notes.push_back("no RPDO" + std::to_string(p));
    }
  }
  for (int p = 1; p <= pdo_count; ++p) {
    const std::uint32_t tx_id = cia301::default_tpdo_id(p, options.node);
    if (p == 1) {
      write_all(cia301::pdo_configuration_sequence(
                    {PdoDirection::transmit, 1, m.tpdo_position_id, 1, m.tpdo_position}),
                false);
    } else if (p == 2 && m.tpdo_velocity) {
      write_all(cia301::pdo_configuration_sequence(
                    {PdoDirection::transmit, 2, m.tpdo_velocity_id, 1, *m.tpdo_velocity}),
                false);
    } else if (!write_all(cia301::pdo_configuration_sequence({PdoDirection::transmit, p, tx_id, 1, {}}),
                          true)) {
      result.notes.push_back("no TPDO" + std::to_string(p));
    }
  }
}

}  // namespace

CyclicMapping standard_mapping(std::uint8_t node, bool velocity) {
  CyclicMapping m;
  const MappingEntry rx[] = {{{obj402::controlword, 0}, 16}, {{obj402::target_torque, 0}, 16}};
  const MappingEntry tx[] = {{{obj402::statusword, 0}, 16}, {{obj402::position_actual, 0}, 32}};
  m.rpdo = cia301::PdoLayout(rx);
  m.rpdo_id = cia301::default_rpdo_id(1, node);
  m.tpdo_position = cia301::PdoLayout(tx);
  m.tpdo_position_id = cia301::default_tpdo_id(1, node);
  if (velocity) {
    const MappingEntry v[] = {{{obj402::velocity_actual, 0}, 32}};
    m.tpdo_velocity = cia301::PdoLayout(v);
    m.tpdo_velocity_id = cia301::default_tpdo_id(2, node);
  }
  return m;
}

std::vector<cia301::CyclicFrame> cyclic_frames(const CyclicMapping& m) {
  std::vector<cia301::CyclicFrame> frames = {
      {"SYNC", 0}, {"RPDO1", m.rpdo.bytes()}, {"TPDO1", m.tpdo_position.bytes()}};
  if (m.tpdo_velocity) frames.push_back({"TPDO2", m.tpdo_velocity->bytes()});
  return frames;
}

namespace {

bool read_optional(SdoClient& sdo, ObjectAddress address, std::uint32_t& value) {
  return step([&] { value = sdo.read(address); }, "", true);
}
bool write_optional(SdoClient& sdo, ObjectAddress address, std::uint32_t value, std::uint8_t size) {
  return step([&] { sdo.write(address, value, size); }, "", true);
}
void write(SdoClient& sdo, ObjectAddress address, std::uint32_t value, std::uint8_t size,
           const std::string& key = "") {
  step([&] { sdo.write(address, value, size); }, key);
}
bool in_fault(std::optional<cia402::DriveState> s) {
  return s == cia402::DriveState::fault || s == cia402::DriveState::fault_reaction_active;
}

// 1. Is it there, and is it a CiA 402 drive?
void identify(SdoClient& sdo, const std::string& node, SetupResult& r) {
  try {
    r.identity.device_type = sdo.read({obj301::device_type, 0});
  } catch (const SdoError& e) {
    const bool silent = e.outcome().kind == SdoOutcome::Kind::timed_out;
    throw SetupError((silent ? node + " does not answer: " : std::string()) + e.what(), "node_id");
  }
  const std::uint32_t profile = r.identity.device_type & 0xFFFFU;
  if (profile != profile_402)
    throw SetupError(node + " is not a CiA 402 drive: 0x1000 device type = " +
                         world::text::format_hex(r.identity.device_type, 8) + " (profile " +
                         std::to_string(profile) + ")",
                     "node_id");
  step([&] { r.identity.vendor_id = sdo.read({obj301::identity, 1}); }, "node_id");
  read_optional(sdo, {obj301::identity, 2}, r.identity.product_code);
  read_optional(sdo, {obj301::identity, 3}, r.identity.revision);
  read_optional(sdo, {obj301::identity, 4}, r.identity.serial);
}

// 3. Cyclic synchronous torque, offered (0x6502) and taken (0x6061 read back).
void select_torque_mode(SdoClient& sdo, const std::string& node, SetupResult& r) {
  const auto cst = cia402::Mode::cyclic_synchronous_torque;
  std::uint32_t modes = 0;
  if (!read_optional(sdo, {obj402::supported_drive_modes, 0}, modes))
    r.notes.push_back("no 0x6502: the mode is confirmed by 0x6061 alone");
  else if ((modes >> *cia402::supported_mode_bit(cst) & 1U) == 0)
    throw SetupError(node + " does not offer cyclic synchronous torque: 0x6502 supported drive modes = " +
                         world::text::format_hex(modes, 8) + " (bit 9 clear)",
                     "node_id");
  (void)node;
  select_mode(sdo, cst, "node_id");
}

// 4. Rated torque (the unit of 0x6071) and the interpolation period.
void units_and_timing(SdoClient& sdo, const SetupOptions& o, SetupResult& r) {
  std::optional<std::uint32_t> drive_mnm;
  try {
    drive_mnm = read_rated_torque(sdo);
  } catch (const SdoError& e) {
    throw SetupError(std::string(e.what()) + ": 0x6076 is the unit of every torque hapticd sends",
                     "rated_torque");
  }
  r.rated_torque_mnm = torque_unit(drive_mnm, o.rated_torque_mnm, o.node);
  r.rated_torque_from_drive = drive_mnm.has_value();
  const auto period = cia402::encode_interpolation_period(o.period_s);
  if (!period)
    throw SetupError("the period " + std::to_string(o.period_s * 1e6) +
                         " us has no exact 0x60C2 form (value x 10^index s): use whole microseconds",
                     "");
  const bool has_60c2 = write_optional(sdo, {obj402::interpolation_time_period, 1}, period->value, 1) &&
                        write_optional(sdo, {obj402::interpolation_time_period, 2},
                                       static_cast<std::uint8_t>(period->exponent), 1);
  if (!has_60c2) r.notes.push_back("no 0x60C2: the drive does not learn the period");
}

// 6. The dead-man: the drive watches hapticd's heartbeat and faults without it.
void arm_dead_man(SdoClient& sdo, const SetupOptions& o, const std::string& node, SetupResult& r) {
  if (!write_optional(sdo, {obj402::abort_connection_option, 0}, cia402::abort_connection::fault, 2))
    r.notes.push_back("no 0x6007: a lost hapticd is handled by the drive's own default");
  write(sdo, {obj301::producer_heartbeat_time, 0}, o.heartbeat_period_ms, 2, "heartbeat_period");
  try {
    sdo.write({obj301::consumer_heartbeat_time, 1},
              cia301::encode_consumer_heartbeat(o.master_node, o.heartbeat_timeout_ms), 4);
  } catch (const SdoError& e) {
    const std::string why = e.object_missing()
                                ? node +
                                      " has no heartbeat consumer (0x1016:01), so it could not "
                                      "stop when hapticd dies; refusing to drive it: "
                                : "";
    throw SetupError(why + e.what(), "heartbeat_timeout");
  }
}

// A fault left from before (a killed hapticd, an earlier error) is reset by
// the controlword's bit 7 edge, and said so; one that stays is fatal.
cia402::DriveState reset_old_fault(SdoClient& sdo, const std::string& node, SetupResult& r) {
  std::uint32_t statusword = 0;
  step([&] { statusword = sdo.read({obj402::statusword, 0}); }, "");
  auto state = cia402::decode_statusword(static_cast<std::uint16_t>(statusword));
  if (in_fault(state)) {
    std::uint32_t code = 0;
    read_optional(sdo, {obj402::error_code, 0}, code);
    const std::string was = "0x603F = " + world::text::format_hex(code, 4) + " (" +
                            describe_error_code(static_cast<std::uint16_t>(code)) + ")";
    for (const std::uint16_t cw : {cia402::controlword::disable_voltage, cia402::controlword::fault_reset,
                                   cia402::controlword::disable_voltage})
      write(sdo, {obj402::controlword, 0}, cw, 2);
    step([&] { statusword = sdo.read({obj402::statusword, 0}); }, "");
    state = cia402::decode_statusword(static_cast<std::uint16_t>(statusword));
    if (in_fault(state)) throw SetupError(node + " stays in Fault after a fault reset: " + was, "");
    r.notes.push_back("reset the fault the drive had: " + was);
  }
  if (!state)
    throw SetupError(
        node + " statusword " + world::text::format_hex(statusword, 4) + " matches no CiA 402 state",
        "node_id");
  return *state;
}

}  // namespace

void select_mode(SdoClient& sdo, cia402::Mode mode, const std::string& key, const std::string& sdo_key) {
  const auto wanted = static_cast<std::int8_t>(mode);
  write(sdo, {obj402::modes_of_operation, 0}, static_cast<std::uint8_t>(wanted), 1, sdo_key);
  std::int8_t shown = 0;
  for (int i = 0; i < mode_confirm_reads && shown != wanted; ++i)
    step(
        [&] {
          shown = static_cast<std::int8_t>(sdo.read({obj402::modes_of_operation_display, 0}) & 0xFFU);
        },
        sdo_key);
  if (shown != wanted)
    throw SetupError(node_name(sdo.node()) + " did not take " + std::string(cia402::to_string(mode)) +
                         ": after 0x6060 = " + std::to_string(wanted) + ", 0x6061 shows " +
                         std::to_string(shown) + " (" + std::string(cia402::describe_mode(shown)) + ")",
                     key);
}

std::optional<std::uint32_t> read_rated_torque(SdoClient& sdo) {
  try {
    return sdo.read({obj402::rated_torque, 0});
  } catch (const SdoError& e) {
    if (e.object_missing()) return std::nullopt;
    throw;
  }
}

std::uint32_t torque_unit(std::optional<std::uint32_t> drive_mnm, std::uint32_t config_mnm,
                          std::uint8_t node) {
  const std::string name = node_name(node);
  if (!drive_mnm) {
    if (config_mnm == 0)
      throw SetupError(name + " has no 0x6076 motor rated torque: set rated_torque in the config",
                       "rated_torque");
    return config_mnm;
  }
  if (*drive_mnm == 0)
    throw SetupError(name + " reports 0x6076 rated torque = 0: set rated_torque in the config",
                     "rated_torque");
  if (config_mnm != 0 && config_mnm != *drive_mnm)
    throw SetupError("rated_torque = " + std::to_string(config_mnm) + " mN m, but " + name +
                         "'s 0x6076 motor rated torque = " + std::to_string(*drive_mnm) +
                         " mN m: the drive scales 0x6071 by its own 0x6076; set rated_torque = 0 (the "
                         "drive's) or correct 0x6076",
                     "rated_torque");
  return *drive_mnm;
}

SetupResult setup_drive(SdoClient& sdo, FrameLink& link, const SetupOptions& o) {
  SetupResult r;
  const std::string node = node_name(o.node);
  link.send(cia301::encode_nmt(cia301::NmtCommand::enter_pre_operational, o.node));
  identify(sdo, node, r);
  // 2. Power stage off and no torque while configuring.
  write(sdo, {obj402::controlword, 0}, cia402::controlword::disable_voltage, 2);
  write(sdo, {obj402::target_torque, 0}, 0, 2);
  select_torque_mode(sdo, node, r);
  units_and_timing(sdo, o, r);
  r.mapping = standard_mapping(o.node, o.velocity);
  configure_pdos(sdo, o, r.mapping, r);  // 5.
  arm_dead_man(sdo, o, node, r);
  r.state = reset_old_fault(sdo, node, r);
  return r;
}

void release_drive(SdoClient& sdo, FrameLink& link, std::uint8_t node) noexcept {
  try {
    sdo.write({obj402::controlword, 0}, cia402::controlword::disable_voltage, 2);
  } catch (...) {
  }
  try {
    sdo.write({obj301::consumer_heartbeat_time, 1}, 0, 4);
  } catch (...) {
  }
  try {
    link.send(cia301::encode_nmt(cia301::NmtCommand::enter_pre_operational, node));
  } catch (...) {
  }
}

}  // namespace hapticd::drivers::canopen
