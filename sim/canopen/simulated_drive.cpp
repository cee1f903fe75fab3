#include "sim/canopen/simulated_drive.hpp"

#include <linux/can.h>
#include <linux/can/error.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "drivers/canopen/301/cob_id.hpp"
#include "drivers/canopen/301/sdo.hpp"
#include "drivers/canopen/402/drive_errors.hpp"

namespace hapticd::drivers::canopen::sim {

using cia301::Frame;
using cia301::NmtState;
using cia301::ObjectAddress;
using cia301::PdoDirection;
using cia402::DriveState;
namespace abort_code = cia301::abort_code;
namespace obj301 = cia301::object;
namespace obj402 = cia402::object;

namespace {

constexpr int pdo_count = 4;
constexpr std::uint8_t consumer_entries = 4;

// CiA 301 restricted CAN-IDs: a PDO must not use them.
bool restricted_id(std::uint32_t id) {
  return id == 0 || (id >= 0x001 && id <= 0x07F) || (id >= 0x101 && id <= 0x180) ||
         (id >= 0x581 && id <= 0x5FF) || (id >= 0x601 && id <= 0x67F) || (id >= 0x6E0 && id <= 0x6FF) ||
         id >= 0x701;
}

std::string hex4(unsigned v) {
  char text[8];
  std::snprintf(text, sizeof text, "0x%04X", v);
  return text;
}

std::uint32_t to_int32_units(double value) {
  const auto counts = static_cast<std::int64_t>(std::llround(value));
  return static_cast<std::uint32_t>(
      static_cast<std::uint64_t>(counts));  // INTEGER32 wraps like a drive's counter
}

}  // namespace

std::uint8_t error_register_for(std::uint16_t code) noexcept {
  namespace reg = cia301::error_register;
  if (code == 0) return 0;
  std::uint8_t r = reg::generic;
  switch (code >> 12) {
    case 0x2:
      r |= reg::current;
      break;
    case 0x3:
      r |= reg::voltage;
      break;
    case 0x4:
      r |= reg::temperature;
      break;
    default:
      if ((code & 0xFF00U) == 0x8100U || (code & 0xFF00U) == 0x8200U) r |= reg::communication;
      break;
  }
  return r;
}

SimulatedDrive::SimulatedDrive(const DriveSettings& settings, DrivePlant& plant)
    : settings_(settings), plant_(plant), consumers_(consumer_entries) {
  build_dictionary();
}

void SimulatedDrive::build_dictionary() {
  const std::uint8_t n = settings_.node_id;
  od_.add({obj301::device_type, 0}, settings_.device_type);
  od_.add({obj301::error_register, 0}, 0);
  od_.add({obj301::consumer_heartbeat_time, 0}, consumer_entries);
  for (std::uint8_t i = 1; i <= consumer_entries; ++i) od_.add({obj301::consumer_heartbeat_time, i}, 0);
  od_.add({obj301::producer_heartbeat_time, 0}, settings_.producer_heartbeat_ms);
  od_.add({obj301::identity, 0}, 4);
  od_.add({obj301::identity, 1}, settings_.vendor_id);
  od_.add({obj301::identity, 2}, settings_.product_code);
  od_.add({obj301::identity, 3}, settings_.revision);
  od_.add({obj301::identity, 4}, settings_.serial);
  od_.add({obj301::error_behavior, 0}, 1);
  od_.add({obj301::error_behavior, 1}, 0);  // communication error: to pre-operational
  for (int p = 1; p <= pdo_count; ++p) {
    const std::uint16_t rc = cia301::pdo_communication_index(PdoDirection::receive, p);
    const std::uint16_t rm = cia301::pdo_mapping_index(PdoDirection::receive, p);
    const std::uint16_t tc = cia301::pdo_communication_index(PdoDirection::transmit, p);
    const std::uint16_t tm = cia301::pdo_mapping_index(PdoDirection::transmit, p);
    // Factory defaults as many drives ship them: RPDO1 = controlword and
    // TPDO1 = statusword, event-driven (255); the others not valid.
    const bool first = p == 1;
    od_.add({rc, 0}, 2);
    od_.add({rc, 1}, cia301::encode_pdo_cob_id({cia301::default_rpdo_id(p, n), first, false}));
    od_.add({rc, 2}, cia301::transmission_type::event_profile);
    od_.add({tc, 0}, 5);
    od_.add({tc, 1}, cia301::encode_pdo_cob_id({cia301::default_tpdo_id(p, n), first, false}));
    od_.add({tc, 2}, cia301::transmission_type::event_profile);
    od_.add({tc, 3}, 0);
    od_.add({tc, 5}, 0);
    od_.add({rm, 0}, first ? 1 : 0);
    od_.add({tm, 0}, first ? 1 : 0);
    for (std::uint8_t s = 1; s <= cia301::max_pdo_entries; ++s) {
      od_.add({rm, s}, first && s == 1 ? cia301::encode_mapping({{obj402::controlword, 0}, 16}) : 0);
      od_.add({tm, s}, first && s == 1 ? cia301::encode_mapping({{obj402::statusword, 0}, 16}) : 0);
    }
  }
  od_.add({obj402::abort_connection_option, 0},
          static_cast<std::uint16_t>(cia402::abort_connection::no_action));
  od_.add({obj402::error_code, 0}, 0);
  od_.add({obj402::controlword, 0}, 0);
  od_.add({obj402::statusword, 0}, 0);
  od_.add({obj402::quick_stop_option, 0}, 2);
  od_.add({obj402::modes_of_operation, 0}, 0);
  od_.add({obj402::modes_of_operation_display, 0}, 0);
  od_.add({obj402::position_actual, 0}, 0);
  od_.add({obj402::velocity_actual, 0}, 0);
  od_.add({obj402::target_torque, 0}, 0);
  od_.add({obj402::max_torque, 0}, 3000);
  od_.add({obj402::rated_torque, 0}, settings_.rated_torque_mnm);
  od_.add({obj402::torque_actual, 0}, 0);
  od_.add({obj402::interpolation_time_period, 0}, 2);
  od_.add({obj402::interpolation_time_period, 1}, 1);
  od_.add({obj402::interpolation_time_period, 2}, static_cast<std::uint8_t>(-3));
  od_.add({obj402::supported_drive_modes, 0}, settings_.supported_modes);
}

// ---- NMT ---------------------------------------------------------------------

void SimulatedDrive::power_on(Micros now, std::vector<Frame>& out) {
  powered_ = true;
  state_ = DriveState::not_ready_to_switch_on;  // transition 0: self-test
  state_ = DriveState::switch_on_disabled;      // transition 1
  reset_communication(now, out);
}

void SimulatedDrive::reset_communication(Micros now, std::vector<Frame>& out) {
  od_.reset(0x1000, 0x1FFF);
  for (Consumer& c : consumers_) c = Consumer{};
  for (RxPdoBuffer& b : rpdo_) b = RxPdoBuffer{};
  std::fill(std::begin(tpdo_sync_count_), std::end(tpdo_sync_count_), 0);
  if (!mute_) out.push_back(cia301::encode_heartbeat(settings_.node_id, NmtState::boot_up));
  enter_nmt(NmtState::pre_operational, now);
}

void SimulatedDrive::enter_nmt(NmtState state, Micros now) {
  // The heartbeat producer starts one period after the boot-up message.
  if (nmt_ == NmtState::boot_up)
    next_heartbeat_ = now + Micros(std::chrono::milliseconds(od_.get({obj301::producer_heartbeat_time, 0})));
  nmt_ = state;
}

void SimulatedDrive::on_nmt(const cia301::NmtMessage& message, Micros now, std::vector<Frame>& out) {
  using cia301::NmtCommand;
  switch (message.command) {
    case NmtCommand::start:
      enter_nmt(NmtState::operational, now);
      break;
    case NmtCommand::stop:
      lost_master(0, "NMT stop while enabled", out);
      enter_nmt(NmtState::stopped, now);
      break;
    case NmtCommand::enter_pre_operational:
      enter_nmt(NmtState::pre_operational, now);
      break;
    case NmtCommand::reset_node:
      od_.reset(0x0000, 0xFFFF);
      state_ = DriveState::switch_on_disabled;
      controlword_ = 0;
      fault_reason_.clear();
      nmt_ = NmtState::boot_up;
      reset_communication(now, out);
      break;
    case NmtCommand::reset_communication:
      lost_master(0, "NMT reset communication while enabled", out);
      nmt_ = NmtState::boot_up;
      reset_communication(now, out);
      break;
  }
}

// ---- frames ------------------------------------------------------------------

void SimulatedDrive::on_frame(const Frame& frame, Micros now, std::vector<Frame>& out) {
  if (mute_ || !powered_ || !cia301::is_standard_data_frame(frame)) return;
  finish_fault_reaction();  // the reaction (power stage off) is over by the next frame
  const std::uint8_t node = settings_.node_id;
  if (const auto nmt = cia301::decode_nmt(frame)) {
    if (cia301::addresses(*nmt, node)) on_nmt(*nmt, now, out);
    return;
  }
  if (nmt_ == NmtState::stopped) {
    if (const auto hb = cia301::decode_heartbeat(frame)) on_heartbeat(*hb, now);
    return;
  }
  if (cia301::is_sync(frame)) {
    on_sync(now, out);
    return;
  }
  if (frame.id == cia301::sdo_request_id(node)) {
    on_sdo(frame, out);
    return;
  }
  if (const auto hb = cia301::decode_heartbeat(frame)) {
    on_heartbeat(*hb, now);
    return;
  }
  if (nmt_ != NmtState::operational) return;
  for (int p = 1; p <= pdo_count; ++p) {
    const cia301::PdoCobId id = cob_id(PdoDirection::receive, p);
    if (id.valid && id.can_id == frame.id) {
      on_rpdo(p, frame, out);
      return;
    }
  }
}

void SimulatedDrive::tick(Micros now, std::vector<Frame>& out) {
  if (mute_ || !powered_) return;
  finish_fault_reaction();
  const std::uint16_t period_ms = static_cast<std::uint16_t>(od_.get({obj301::producer_heartbeat_time, 0}));
  if (period_ms != 0 && now >= next_heartbeat_) {
    out.push_back(cia301::encode_heartbeat(settings_.node_id, nmt_));
    ++counters_.heartbeats_sent;
    const Micros period = std::chrono::milliseconds(period_ms);
    next_heartbeat_ += period;
    if (next_heartbeat_ <= now) next_heartbeat_ = now + period;  // late: do not burst
  }
  for (std::uint8_t i = 0; i < consumer_entries; ++i) {
    Consumer& c = consumers_[i];
    const auto entry =
        cia301::decode_consumer_heartbeat(od_.get({obj301::consumer_heartbeat_time, std::uint8_t(i + 1)}));
    if (!entry.used() || !c.active) continue;
    if (now - c.last > Micros(std::chrono::milliseconds(entry.time_ms))) {
      c.active = false;  // monitoring restarts with the next heartbeat
      ++counters_.heartbeat_timeouts;
      lost_master(cia301::emcy_code::heartbeat,
                  "heartbeat of node " + std::to_string(entry.node) + " lost (consumer time " +
                      std::to_string(entry.time_ms) + " ms)",
                  out);
    }
  }
}

Micros SimulatedDrive::next_deadline() const noexcept {
  Micros next = Micros::max();
  if (od_.get({obj301::producer_heartbeat_time, 0}) != 0) next = next_heartbeat_;
  for (std::uint8_t i = 0; i < consumer_entries; ++i) {
    const Consumer& c = consumers_[i];
    const auto entry =
        cia301::decode_consumer_heartbeat(od_.get({obj301::consumer_heartbeat_time, std::uint8_t(i + 1)}));
    if (entry.used() && c.active)
      next = std::min(next, c.last + Micros(std::chrono::milliseconds(entry.time_ms)) + Micros(1));
  }
  return next;
}

void SimulatedDrive::on_heartbeat(const cia301::Heartbeat& hb, Micros now) {
  for (std::uint8_t i = 0; i < consumer_entries; ++i) {
    const auto entry =
        cia301::decode_consumer_heartbeat(od_.get({obj301::consumer_heartbeat_time, std::uint8_t(i + 1)}));
    if (!entry.used() || entry.node != hb.node) continue;
    // Monitoring starts with the first heartbeat, not the boot-up (CiA 301).
    consumers_[i].active = hb.state != NmtState::boot_up;
    consumers_[i].last = now;
  }
}

// ---- SDO server --------------------------------------------------------------

void SimulatedDrive::on_sdo(const Frame& frame, std::vector<Frame>& out) {
  const std::uint8_t node = settings_.node_id;
  const auto request = cia301::decode_sdo_request(frame, node);
  if (!request) return;
  ++counters_.sdo_requests;
  using Kind = cia301::SdoRequest::Kind;
  if (request->kind == Kind::abort) return;  // nothing in progress in an expedited-only server
  auto abort = [&](std::uint32_t code) {
    ++counters_.sdo_aborts;
    out.push_back(cia301::encode_server_abort(node, request->address, code));
  };
  if (abort_pending_ && (!abort_address_ || *abort_address_ == request->address)) {
    abort_pending_ = false;
    abort(abort_code_);
    return;
  }
  switch (request->kind) {
    case Kind::upload: {
      refresh_process_values();
      if (const std::uint32_t code = od_.check_read(request->address)) return abort(code);
      const Entry* e = od_.find(request->address);
      out.push_back(
          cia301::encode_upload_response(node, request->address, e->value, cia301::size_of(e->info.type)));
      return;
    }
    case Kind::download_expedited: {
      if (const std::uint32_t code = sdo_download(request->address, request->value, request->size))
        return abort(code);
      out.push_back(cia301::encode_download_response(node, request->address));
      if (request->address == ObjectAddress{obj402::controlword, 0})
        on_controlword(static_cast<std::uint16_t>(request->value), out);
      return;
    }
    case Kind::download_segmented:
    case Kind::unknown:
    case Kind::abort:
      return abort(abort_code::unknown_command);
  }
}

std::uint32_t SimulatedDrive::sdo_download(ObjectAddress address, std::uint32_t value, std::uint8_t size) {
  if (const std::uint32_t code = od_.check_write(address, size)) return code;
  if (const std::uint32_t code = check_pdo_write(address, value)) return code;
  if (const std::uint32_t code = check_drive_write(address, value)) return code;
  const std::uint32_t old = od_.get(address);
  od_.set(address, value);
  after_write(address, old);
  return 0;
}

std::uint32_t SimulatedDrive::check_pdo_write(ObjectAddress a, std::uint32_t value) const {
  const auto pdo = cia301::pdo_of_index(a.index);
  if (!pdo) return 0;
  const cia301::PdoCobId current = cob_id(pdo->direction, pdo->number);
  const std::uint16_t map = cia301::pdo_mapping_index(pdo->direction, pdo->number);
  if (!pdo->mapping) {
    if (a.sub == 1) {
      const cia301::PdoCobId next = cia301::decode_pdo_cob_id(value);
      if ((value & 0x3FFFF800U) != 0) return abort_code::invalid_value;  // 29-bit ids not supported
      if (next.valid && current.valid && next.can_id != current.can_id) return abort_code::invalid_value;
      if (next.valid && (restricted_id(next.can_id) || od_.get({map, 0}) == 0))
        return abort_code::invalid_value;
    }
    if (a.sub == 2 && value > cia301::transmission_type::max_cyclic &&
        value < cia301::transmission_type::event_manufacturer)
      return abort_code::invalid_value;
    return 0;
  }
  // Mapping: only while the PDO is not valid, and entries only while the count is 0.
  if (current.valid || (a.sub != 0 && od_.get({map, 0}) != 0)) return abort_code::wrong_state;
  const cia301::Mappable wanted =
      pdo->direction == PdoDirection::receive ? cia301::Mappable::rpdo : cia301::Mappable::tpdo;
  auto entry_ok = [&](std::uint32_t raw) {
    const cia301::MappingEntry e = cia301::decode_mapping(raw);
    const Entry* target = od_.find(e.object);
    return target != nullptr && target->info.mappable == wanted &&
           e.bits == 8U * cia301::size_of(target->info.type);
  };
  if (a.sub != 0) return value == 0 || entry_ok(value) ? 0 : abort_code::not_mappable;
  if (value > cia301::max_pdo_entries) return abort_code::mapping_too_long;
  std::uint32_t bits = 0;
  for (std::uint32_t s = 1; s <= value; ++s) {
    const std::uint32_t raw = od_.get({map, static_cast<std::uint8_t>(s)});
    if (!entry_ok(raw)) return abort_code::not_mappable;
    bits += cia301::decode_mapping(raw).bits;
  }
  return bits > cia301::max_pdo_bits ? abort_code::mapping_too_long : 0;
}

std::uint32_t SimulatedDrive::check_drive_write(ObjectAddress a, std::uint32_t value) const {
  if (a == ObjectAddress{obj402::modes_of_operation, 0}) {
    const auto mode = static_cast<std::int8_t>(value & 0xFFU);
    if (mode == 0) return 0;
    const auto bit = cia402::supported_mode_bit(static_cast<cia402::Mode>(mode));
    const std::uint32_t supported = od_.get({obj402::supported_drive_modes, 0});
    return bit && (supported >> *bit & 1U) != 0 ? 0 : abort_code::invalid_value;
  }
  if (a == ObjectAddress{obj402::abort_connection_option, 0}) {
    const auto option = static_cast<std::int16_t>(value & 0xFFFFU);
    return option >= 0 && option <= 3 ? 0 : abort_code::invalid_value;
  }
  if (a == ObjectAddress{obj301::error_behavior, 1}) return value <= 2 ? 0 : abort_code::invalid_value;
  if (a.index == obj301::consumer_heartbeat_time && a.sub >= 1) {
    const auto next = cia301::decode_consumer_heartbeat(value);
    if ((value >> 24) != 0) return abort_code::invalid_value;
    if (!next.used()) return 0;
    for (std::uint8_t s = 1; s <= consumer_entries; ++s) {
      if (s == a.sub) continue;
      const auto other = cia301::decode_consumer_heartbeat(od_.get({obj301::consumer_heartbeat_time, s}));
      if (other.used() && other.node == next.node) return abort_code::parameter_incompatible;
    }
  }
  return 0;
}

void SimulatedDrive::after_write(ObjectAddress a, std::uint32_t old_value) {
  (void)old_value;
  if (a == ObjectAddress{obj402::modes_of_operation, 0} && !refuse_mode_)
    od_.set({obj402::modes_of_operation_display, 0}, od_.get(a));
  if (a.index == obj301::consumer_heartbeat_time && a.sub >= 1 && a.sub <= consumer_entries)
    consumers_[a.sub - 1] = Consumer{};
  if (a == ObjectAddress{obj301::producer_heartbeat_time, 0})
    next_heartbeat_ = Micros{0};  // due at the next tick
}

void SimulatedDrive::abort_next_sdo(std::optional<ObjectAddress> address, std::uint32_t code) noexcept {
  abort_pending_ = true;
  abort_address_ = address;
  abort_code_ = code;
}

// ---- PDOs and SYNC -----------------------------------------------------------

cia301::PdoCobId SimulatedDrive::cob_id(PdoDirection direction, int number) const {
  return cia301::decode_pdo_cob_id(od_.get({cia301::pdo_communication_index(direction, number), 1}));
}

std::optional<cia301::PdoLayout> SimulatedDrive::layout(PdoDirection direction, int number) const {
  const std::uint16_t map = cia301::pdo_mapping_index(direction, number);
  const std::uint32_t count = od_.get({map, 0});
  cia301::MappingEntry entries[cia301::max_pdo_entries];
  for (std::uint8_t s = 1; s <= count && s <= cia301::max_pdo_entries; ++s)
    entries[s - 1] = cia301::decode_mapping(od_.get({map, s}));
  try {
    return cia301::PdoLayout(std::span<const cia301::MappingEntry>(entries, std::min<std::size_t>(count, 8)));
  } catch (const std::invalid_argument&) {
    return std::nullopt;  // cannot happen: writes were checked
  }
}

void SimulatedDrive::on_rpdo(int number, const Frame& frame, std::vector<Frame>& out) {
  ++counters_.rpdos_received;
  const auto l = layout(PdoDirection::receive, number);
  if (!l || frame.len < l->bytes()) {
    ++counters_.rpdo_length_errors;
    send_emcy(cia301::emcy_code::pdo_length, error_register_for(cia301::emcy_code::pdo_length), out);
    return;
  }
  const auto type =
      static_cast<std::uint8_t>(od_.get({cia301::pdo_communication_index(PdoDirection::receive, number), 2}));
  if (cia301::is_synchronous(type)) {
    rpdo_[number - 1] = RxPdoBuffer{true, frame};  // takes effect at the next SYNC
  } else {
    apply_rpdo(number, frame, out);
  }
}

void SimulatedDrive::apply_rpdo(int number, const Frame& frame, std::vector<Frame>& out) {
  const auto l = layout(PdoDirection::receive, number);
  if (!l) return;
  std::uint32_t values[cia301::max_pdo_entries] = {};
  if (!l->unpack(frame, values)) return;
  for (std::size_t i = 0; i < l->count(); ++i) {
    const ObjectAddress a = l->entry(i).object;
    if (a == ObjectAddress{obj402::controlword, 0}) {
      on_controlword(static_cast<std::uint16_t>(values[i]), out);
    } else {
      od_.set(a, values[i]);
      if (a == ObjectAddress{obj402::modes_of_operation, 0} && !refuse_mode_)
        od_.set({obj402::modes_of_operation_display, 0}, values[i]);
    }
  }
}

void SimulatedDrive::on_sync(Micros now, std::vector<Frame>& out) {
  (void)now;
  ++counters_.syncs;
  finish_fault_reaction();
  if (nmt_ == NmtState::operational) {
    for (int p = 1; p <= pdo_count; ++p) {
      RxPdoBuffer& b = rpdo_[p - 1];
      if (!b.pending) continue;
      b.pending = false;
      apply_rpdo(p, b.frame, out);
    }
  }
  // Quick stop in torque mode: torque to zero at once, then Switch On Disabled (0x605A = 2).
  if (state_ == DriveState::quick_stop_active) state_ = DriveState::switch_on_disabled;
  double force = 0.0;
  const bool halt = (controlword_ & cia402::control_bit::halt) != 0;
  if (cia402::power_stage_on(state_) && !halt &&
      mode_display() == static_cast<std::int8_t>(cia402::Mode::cyclic_synchronous_torque)) {
    const auto target = static_cast<std::int16_t>(od_.get({obj402::target_torque, 0}));
    const auto limit = static_cast<int>(od_.get({obj402::max_torque, 0}));
    const int permille = std::clamp<int>(target, -limit, limit);
    force = permille * 1e-3 * od_.get({obj402::rated_torque, 0}) * 1e-3;
  }
  applied_force_ = force;
  if (nmt_ == NmtState::operational) send_tpdos(out);
  plant_.step(force);
}

void SimulatedDrive::send_tpdos(std::vector<Frame>& out) {
  refresh_process_values();
  for (int p = 1; p <= pdo_count; ++p) {
    const cia301::PdoCobId id = cob_id(PdoDirection::transmit, p);
    const auto type =
        static_cast<std::uint8_t>(od_.get({cia301::pdo_communication_index(PdoDirection::transmit, p), 2}));
    if (!id.valid || !cia301::is_synchronous(type)) continue;
    const std::uint8_t every = type == 0 ? 1 : type;
    if (++tpdo_sync_count_[p - 1] < every) continue;
    tpdo_sync_count_[p - 1] = 0;
    const auto l = layout(PdoDirection::transmit, p);
    if (!l || l->count() == 0) continue;
    if (drop_tpdos_ != 0) {
      if (drop_tpdos_ > 0) --drop_tpdos_;
      ++counters_.tpdos_dropped;
      continue;
    }
    std::uint32_t values[cia301::max_pdo_entries] = {};
    for (std::size_t i = 0; i < l->count(); ++i) values[i] = od_.get(l->entry(i).object);
    out.push_back(l->pack(id.can_id, values));
    ++counters_.tpdos_sent;
  }
}

void SimulatedDrive::refresh_process_values() {
  od_.set({obj402::statusword, 0}, statusword());
  od_.set({obj402::position_actual, 0},
          to_int32_units(plant_.position() * settings_.position_units_per_si) +
              static_cast<std::uint32_t>(static_cast<std::uint64_t>(position_offset_counts_)));
  od_.set({obj402::velocity_actual, 0}, to_int32_units(plant_.velocity() * settings_.velocity_units_per_si));
  const double rated_nm = od_.get({obj402::rated_torque, 0}) * 1e-3;
  const double permille = rated_nm > 0.0 ? applied_force_ / rated_nm * 1e3 : 0.0;
  od_.set({obj402::torque_actual, 0},
          static_cast<std::uint16_t>(static_cast<std::int16_t>(std::lround(permille))));
}

// ---- CiA 402 state machine ---------------------------------------------------

void SimulatedDrive::on_controlword(std::uint16_t cw, std::vector<Frame>& out) {
  const cia402::Command command = cia402::decode_controlword(controlword_, cw);
  const DriveState before = state_;
  state_ = cia402::next_state(state_, command);
  controlword_ = cw;
  od_.set({obj402::controlword, 0}, cw);
  if (before == DriveState::fault && state_ == DriveState::switch_on_disabled) {
    // Transition 15: the error is reset, and said so with the EMCY "error reset" (code 0x0000).
    od_.set({obj402::error_code, 0}, 0);
    od_.set({obj301::error_register, 0}, 0);
    fault_reason_.clear();
    send_emcy(cia301::emcy_code::no_error, 0, out);
  }
}

std::uint16_t SimulatedDrive::statusword() const noexcept {
  namespace bit = cia402::status_bit;
  std::uint16_t sw = cia402::state_bits(state_);
  if (state_ != DriveState::not_ready_to_switch_on) sw |= bit::voltage_enabled;
  if (state_ != DriveState::quick_stop_active && state_ != DriveState::switch_on_disabled &&
      state_ != DriveState::not_ready_to_switch_on && state_ != DriveState::fault &&
      state_ != DriveState::fault_reaction_active)
    sw |= bit::quick_stop;  // 1 = quick stop not active
  sw |= bit::remote;
  if (state_ == DriveState::operation_enabled && (controlword_ & cia402::control_bit::halt) == 0 &&
      mode_display() == static_cast<std::int8_t>(cia402::Mode::cyclic_synchronous_torque))
    sw |= bit::following_command;
  return sw;
}

std::int8_t SimulatedDrive::mode_display() const noexcept {
  return static_cast<std::int8_t>(od_.get({obj402::modes_of_operation_display, 0}) & 0xFFU);
}

std::uint16_t SimulatedDrive::error_code() const noexcept {
  return static_cast<std::uint16_t>(od_.get({obj402::error_code, 0}));
}

void SimulatedDrive::send_emcy(std::uint16_t code, std::uint8_t error_register, std::vector<Frame>& out) {
  if (mute_) return;
  cia301::Emergency e;
  e.error_code = code;
  e.error_register = error_register;
  out.push_back(cia301::encode_emergency(settings_.node_id, e));
  ++counters_.emcys_sent;
}

void SimulatedDrive::fault(std::uint16_t code, std::uint8_t error_register, const std::string& reason,
                           std::vector<Frame>& out) {
  od_.set({obj402::error_code, 0}, code);
  od_.set({obj301::error_register, 0}, error_register);
  fault_reason_ = reason.empty() ? cia402::describe_error_code(code) : reason;
  state_ = cia402::on_fault(state_);  // transition 13: the power stage is off from here
  applied_force_ = 0.0;
  send_emcy(code, error_register, out);
}

void SimulatedDrive::finish_fault_reaction() {
  if (state_ == DriveState::fault_reaction_active) state_ = DriveState::fault;  // transition 14
}

void SimulatedDrive::lost_master(std::uint16_t emcy_code, const std::string& reason,
                                 std::vector<Frame>& out) {
  const auto option = static_cast<std::int16_t>(od_.get({obj402::abort_connection_option, 0}));
  const bool enabled = state_ == DriveState::operation_enabled;
  std::uint8_t reg = error_register_for(emcy_code);
  if (option == cia402::abort_connection::fault && enabled) {
    fault(emcy_code == 0 ? cia301::emcy_code::generic : emcy_code,
          reg == 0 ? cia301::error_register::generic : reg, reason, out);
  } else {
    if (emcy_code != 0) send_emcy(emcy_code, reg, out);
    if (option == cia402::abort_connection::disable_voltage)
      state_ = cia402::next_state(state_, cia402::Command::disable_voltage);
    if (option == cia402::abort_connection::quick_stop)
      state_ = cia402::next_state(state_, cia402::Command::quick_stop);
  }
  // CiA 301 0x1029: a communication error takes an operational node to pre-operational (0), keeps it (1), or
  // stops it (2).
  if (emcy_code == cia301::emcy_code::heartbeat && nmt_ == NmtState::operational) {
    const std::uint32_t behavior = od_.get({obj301::error_behavior, 1});
    if (behavior == 0) nmt_ = NmtState::pre_operational;
    if (behavior == 2) nmt_ = NmtState::stopped;
  }
}

void SimulatedDrive::inject_fault(const EmergencyFault& f, Micros now, std::vector<Frame>& out) {
  (void)now;
  const std::uint8_t reg = f.error_register ? *f.error_register : error_register_for(f.error_code);
  fault(f.error_code, reg, "EMCY " + hex4(f.error_code) + ": " + cia402::describe_error_code(f.error_code),
        out);
}

void SimulatedDrive::go_bus_off(Micros now, std::vector<Frame>& out) {
  (void)now;
  Frame error;
  error.id = CAN_ERR_FLAG | CAN_ERR_BUSOFF;
  error.len = 8;
  out.push_back(error);
  lost_master(0, "CAN bus-off", out);
  mute_ = true;
}

void SimulatedDrive::clear_switches() noexcept {
  mute_ = false;
  drop_tpdos_ = 0;
  abort_pending_ = false;
  abort_address_.reset();
  refuse_mode_ = false;
}

}  // namespace hapticd::drivers::canopen::sim
