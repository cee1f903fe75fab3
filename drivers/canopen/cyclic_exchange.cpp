#include "drivers/canopen/cyclic_exchange.hpp"

#include <cmath>
#include <cstdio>
#include <system_error>

#include "drivers/canopen/301/cob_id.hpp"
#include "drivers/canopen/402/drive_errors.hpp"
#include "drivers/canopen/402/homing.hpp"
#include "drivers/canopen/402/objects.hpp"
#include "world/text.hpp"

namespace hapticd::drivers::canopen {

using cia301::Frame;
using cia402::DriveState;
namespace obj402 = cia402::object;

namespace {

// An EMCY arriving this many periods after a statusword fault tells the
// same story with the drive's own code: it replaces the latched reason.
constexpr std::uint64_t emcy_upgrade_periods = 3;

std::string state_words(std::uint16_t statusword) {
  const auto s = cia402::decode_statusword(statusword);
  return "statusword " + world::text::format_hex(statusword, 4) + " (" +
         (s ? std::string(cia402::to_string(*s)) : std::string("no CiA 402 state")) + ")";
}

std::string hex3(unsigned v) {
  char text[8];
  std::snprintf(text, sizeof text, "0x%03X", v);
  return text;
}

std::string data_bytes(const Frame& f) {
  std::string out;
  for (std::size_t i = 0; i < f.len && i < f.data.size(); ++i) {
    char b[4];
    std::snprintf(b, sizeof b, "%02X", f.data[i]);
    out += (out.empty() ? "" : " ") + std::string(b);
  }
  return out;
}

std::string malformed_words(const FaultRecord& f) {
  const std::string bytes = std::to_string(f.frame.len) + (f.frame.len == 1 ? " byte" : " bytes") +
                            (f.frame.len == 0 ? std::string() : " (" + data_bytes(f.frame) + ")");
  switch (f.malformed) {
    case MalformedFrame::emcy_length:
      return "an EMCY of " + bytes + " on " + hex3(f.frame.id) +
             ": CiA 301 EMCY has 8 (error code, error register, 5 manufacturer bytes)";
    case MalformedFrame::heartbeat_length:
      return "a heartbeat of " + bytes + " on " + hex3(f.frame.id) +
             ": CiA 301 heartbeat has 1 (the NMT state)";
    case MalformedFrame::heartbeat_state: {
      char state[8];
      std::snprintf(state, sizeof state, "0x%02X", f.frame.data[0]);
      return "heartbeat state " + std::string(state) + " on " + hex3(f.frame.id) +
             ": no NMT state (CiA 301: 0x00 boot-up, 0x04 stopped, 0x05 operational, 0x7F pre-operational)";
    }
    case MalformedFrame::none:
      break;
  }
  return "a malformed frame on " + hex3(f.frame.id) + ": " + bytes;
}

}  // namespace

CyclicExchange::CyclicExchange(const CyclicSettings& settings)
    : settings_(settings), force_per_permille_(settings.scaling.force_per_permille) {}

FrameUse CyclicExchange::on_frame(const Frame& frame) noexcept {
  if ((frame.id & cia301::can_err_flag) != 0) {
    ++counters_.error_frames;
    const BusError error = decode_error_frame(frame);
    if (error.severity == BusErrorSeverity::fault) {
      FaultRecord r;
      r.kind = FaultKind::bus_error;
      r.bus = error;
      latch(r);
    }
    return FrameUse::cyclic;
  }
  if (!cia301::is_standard_data_frame(frame)) return FrameUse::ignored;
  const CyclicMapping& m = settings_.mapping;
  const std::uint8_t node = settings_.node;
  if (frame.id == m.tpdo_position_id) {
    on_tpdo_position(frame);
    return FrameUse::cyclic;
  }
  if (m.tpdo_velocity && frame.id == m.tpdo_velocity_id) {
    on_tpdo_velocity(frame);
    return FrameUse::cyclic;
  }
  if (frame.id == cia301::emcy_id(node)) {
    on_emergency(frame);
    return FrameUse::cyclic;
  }
  if (frame.id == cia301::heartbeat_id(node)) {
    on_drive_heartbeat(frame);
    return FrameUse::cyclic;
  }
  if (frame.id == cia301::sdo_response_id(node)) return FrameUse::sdo_response;
  return FrameUse::ignored;
}

void CyclicExchange::on_emergency(const Frame& frame) noexcept {
  ++counters_.emcys;
  const auto emcy = cia301::decode_emergency(frame, settings_.node);
  if (!emcy) {  // the id is the drive's EMCY: the length is wrong
    latch_malformed(MalformedFrame::emcy_length, frame);
    return;
  }
  if (emcy->error_code == cia301::emcy_code::no_error) return;
  FaultRecord r;
  r.kind = FaultKind::emcy;
  r.emcy = *emcy;
  r.statusword = statusword_;
  latch(r);
}

void CyclicExchange::on_drive_heartbeat(const Frame& frame) noexcept {
  if (frame.len != 1) {
    latch_malformed(MalformedFrame::heartbeat_length, frame);
    return;
  }
  const auto hb = cia301::decode_heartbeat(frame);
  if (!hb) {
    latch_malformed(MalformedFrame::heartbeat_state, frame);
    return;
  }
  ++counters_.drive_heartbeats;
  const bool was_operational = drive_heartbeat_seen_ && drive_nmt_ == cia301::NmtState::operational;
  drive_heartbeat_seen_ = true;
  periods_since_heartbeat_ = 0;
  drive_nmt_ = hb->state;
  FaultRecord r;
  r.nmt = hb->state;
  if (hb->state == cia301::NmtState::boot_up) {
    // Only a restart sends it after the setup: the mapping, the mode and the
    // dead-man hapticd wrote may be back to the drive's defaults.
    r.kind = FaultKind::drive_restarted;
    latch(r);
  } else if (hb->state != cia301::NmtState::operational && !resetting_ && (was_operational || enabled_)) {
    // Stopped or pre-operational: the drive takes no RPDO (CiA 301), so the
    // torque hapticd sends is not what it applies.
    r.kind = FaultKind::left_operational;
    latch(r);
  }
}

void CyclicExchange::latch_malformed(MalformedFrame what, const Frame& frame) noexcept {
  ++counters_.malformed_frames;
  FaultRecord r;
  r.kind = FaultKind::malformed_frame;
  r.malformed = what;
  r.frame = frame;
  latch(r);
}

void CyclicExchange::on_malformed_message(const MalformedMessage& message) noexcept {
  ++counters_.malformed_messages;
  FaultRecord r;
  r.kind = FaultKind::malformed_message;
  r.message = message;
  latch(r);
}

void CyclicExchange::on_torque_unit_changed(std::uint32_t before_mnm, std::uint32_t after_mnm) noexcept {
  FaultRecord r;
  r.kind = FaultKind::torque_unit_changed;
  r.rated_before = before_mnm;
  r.rated_after = after_mnm;
  latch(r);
}

void CyclicExchange::on_tpdo_position(const Frame& frame) noexcept {
  const cia301::PdoLayout& layout = settings_.mapping.tpdo_position;
  std::uint32_t values[cia301::max_pdo_entries] = {};
  if (!layout.unpack(frame, values)) {
    ++counters_.short_tpdos;
    return;
  }
  ++counters_.tpdos;
  if (const auto i = layout.find({obj402::statusword, 0}))
    statusword_ = static_cast<std::uint16_t>(values[*i]);
  if (const auto i = layout.find({obj402::position_actual, 0})) {
    const auto raw = static_cast<std::int32_t>(values[*i]);
    // INTEGER32 wraps; the difference does not (up to 2^31 counts per period).
    position_counts_ =
        have_position_
            ? position_counts_ + static_cast<std::int32_t>(static_cast<std::uint32_t>(raw) -
                                                           static_cast<std::uint32_t>(last_raw_position_))
            : raw;
    last_raw_position_ = raw;
    have_position_ = true;
    fresh_position_ = true;
  }
  check_statusword();
}

void CyclicExchange::on_tpdo_velocity(const Frame& frame) noexcept {
  std::uint32_t values[cia301::max_pdo_entries] = {};
  if (!settings_.mapping.tpdo_velocity->unpack(frame, values)) {
    ++counters_.short_tpdos;
    return;
  }
  velocity_ = static_cast<std::int32_t>(values[0]) * settings_.scaling.si_per_velocity_unit;
}

void CyclicExchange::check_statusword() noexcept {
  const auto state = cia402::decode_statusword(statusword_);
  const bool fault_state = state == DriveState::fault || state == DriveState::fault_reaction_active;
  if (resetting_) {
    if (enabled_ && state == DriveState::operation_enabled) {
      resetting_ = false;
      was_operation_enabled_ = true;
    }
    return;
  }
  if (fault_state) {
    FaultRecord r;
    r.kind = FaultKind::drive_fault;
    r.statusword = statusword_;
    latch(r);
  } else if (enabled_ && was_operation_enabled_ && state != DriveState::operation_enabled) {
    FaultRecord r;
    r.kind = FaultKind::left_enabled;
    r.statusword = statusword_;
    latch(r);
  }
  if (enabled_ && state == DriveState::operation_enabled) was_operation_enabled_ = true;
}

void CyclicExchange::on_link_lost(int error, bool closed) noexcept {
  FaultRecord r;
  r.kind = FaultKind::link_lost;
  r.link_errno = error;
  r.link_closed = closed;
  latch(r);
}

void CyclicExchange::latch(FaultRecord record) noexcept {
  record.period = counters_.periods;
  if (faulted()) {
    const bool vague = fault_.kind == FaultKind::drive_fault || fault_.kind == FaultKind::left_enabled;
    if (vague && record.kind == FaultKind::emcy && record.period - fault_.period <= emcy_upgrade_periods)
      fault_ = record;
    return;
  }
  fault_ = record;
  resetting_ = false;
}

CycleReading CyclicExchange::begin_period() noexcept {
  ++counters_.periods;
  if (fresh_position_) {
    missing_periods_ = 0;
  } else {
    ++missing_periods_;
    if (have_position_) ++counters_.late_tpdos;
  }
  if (!resetting_ && missing_periods_ >= settings_.tpdo_timeout_periods) {
    FaultRecord r;
    r.kind = FaultKind::tpdo_timeout;
    r.periods = missing_periods_;
    latch(r);
  }
  if (drive_heartbeat_seen_) {
    ++periods_since_heartbeat_;
    if (!resetting_ && settings_.drive_heartbeat_timeout_periods != 0 &&
        periods_since_heartbeat_ > settings_.drive_heartbeat_timeout_periods) {
      FaultRecord r;
      r.kind = FaultKind::heartbeat_lost;
      r.periods = periods_since_heartbeat_;
      latch(r);
    }
  }
  if (resetting_ && counters_.periods - reset_started_ > settings_.reset_timeout_periods) {
    resetting_ = false;
    FaultRecord r;
    r.kind = FaultKind::reset_failed;
    r.statusword = statusword_;
    r.periods = settings_.reset_timeout_periods;
    latch(r);
  }
  CycleReading reading;
  reading.valid = have_position_;
  reading.fresh = fresh_position_;
  reading.position = static_cast<double>(position_counts_) * settings_.scaling.si_per_count;
  reading.velocity = velocity_;
  reading.statusword = statusword_;
  fresh_position_ = false;
  return reading;
}

std::size_t CyclicExchange::end_period(double force, std::span<Frame, 4> out) noexcept {
  const auto state = drive_state();
  std::uint16_t cw = cia402::controlword::disable_voltage;
  if (!faulted() && (enabled_ || resetting_))
    cw = state ? cia402::controlword_towards_enabled(*state, controlword_)
               : cia402::controlword::disable_voltage;
  const bool command_flows =
      std::isfinite(force) && enabled_ && !faulted() && !resetting_ && state == DriveState::operation_enabled;
  std::int16_t torque = 0;
  if (command_flows && force_per_permille_ != 0.0) {
    const double permille = std::round(force / force_per_permille_);
    torque = static_cast<std::int16_t>(std::fmax(-32767.0, std::fmin(32767.0, permille)));
  } else {
    cw |= cia402::control_bit::halt;  // halt clear only while a valid command flows
  }
  if (command_flows && homing_start_) cw |= cia402::homing_operation_start;
  controlword_ = cw;
  torque_ = torque;

  std::size_t n = 0;
  const bool heartbeat_due = periods_to_heartbeat_ == 0;
  periods_to_heartbeat_ = heartbeat_due ? settings_.heartbeat_every_periods - 1 : periods_to_heartbeat_ - 1;
  if (resetting_ && heartbeat_due && drive_heartbeat_seen_ && drive_nmt_ != cia301::NmtState::operational)
    out[n++] = cia301::encode_nmt(cia301::NmtCommand::start, settings_.node);
  const std::uint32_t values[2] = {cw, static_cast<std::uint16_t>(torque)};
  out[n++] = settings_.mapping.rpdo.pack(settings_.mapping.rpdo_id, values);
  out[n++] = cia301::encode_sync();
  if (heartbeat_due)
    out[n++] = cia301::encode_heartbeat(settings_.master_node, cia301::NmtState::operational);
  return n;
}

void CyclicExchange::set_enabled(bool enabled) noexcept {
  // A heartbeat at once: the drive's consumer watches hapticd from the first one on.
  if (enabled && !enabled_) periods_to_heartbeat_ = 0;
  enabled_ = enabled;
  if (!enabled) was_operation_enabled_ = false;
}

void CyclicExchange::request_fault_reset() noexcept {
  fault_ = FaultRecord{};
  resetting_ = true;
  reset_started_ = counters_.periods;
  missing_periods_ = 0;
  periods_since_heartbeat_ = 0;
  was_operation_enabled_ = false;
  periods_to_heartbeat_ = 0;  // NMT start (if needed) and a heartbeat at once
}

bool CyclicExchange::operational() const noexcept {
  return !faulted() && !resetting_ && enabled_ && drive_state() == DriveState::operation_enabled;
}

std::optional<DriveState> CyclicExchange::drive_state() const noexcept {
  if (!have_position_ && statusword_ == 0) return std::nullopt;
  return cia402::decode_statusword(statusword_);
}

std::string describe(const FaultRecord& f, const CyclicSettings& s) {
  const std::string node = "node " + std::to_string(s.node);
  switch (f.kind) {
    case FaultKind::none:
      return "";
    case FaultKind::emcy:
      return node + " " + cia402::describe_emergency(f.emcy);
    case FaultKind::drive_fault:
      return node + " is in fault: " + state_words(f.statusword) + ", no EMCY received";
    case FaultKind::left_enabled:
      return node + " left Operation Enabled on its own: " + state_words(f.statusword);
    case FaultKind::tpdo_timeout:
      return "no TPDO1 (" + hex3(s.mapping.tpdo_position_id) + ") from " + node + " for " +
             std::to_string(f.periods) + " periods";
    case FaultKind::heartbeat_lost:
      return "no heartbeat from " + node + " for " + std::to_string(f.periods) + " periods";
    case FaultKind::left_operational:
      return node + " left NMT operational: its heartbeat says " + std::string(cia301::to_string(f.nmt));
    case FaultKind::bus_error:
      return describe(f.bus);
    case FaultKind::link_lost:
      return f.link_closed
                 ? "the bus connection closed (the simulated drive's bus program ended?)"
                 : "CAN socket error: " + std::error_code(f.link_errno, std::generic_category()).message();
    case FaultKind::reset_failed:
      return "the fault reset did not bring " + node + " back to Operation Enabled within " +
             std::to_string(f.periods) + " periods: " + state_words(f.statusword);
    case FaultKind::malformed_frame:
      return node + " sent " + malformed_words(f);
    case FaultKind::malformed_message:
      return describe(f.message);
    case FaultKind::drive_restarted:
      return node + " restarted (its boot-up message on " + hex3(cia301::heartbeat_id(s.node)) +
             "): the PDO mapping, mode and dead-man hapticd set up may be lost; restart hapticd to "
             "configure it again";
    case FaultKind::torque_unit_changed:
      if (f.rated_after == 0)
        return node +
               "'s 0x6076 motor rated torque, the unit of every torque hapticd sends, could not be "
               "read back after an SDO write: torque held at zero; fault clear reads it again";
      return node + "'s 0x6076 motor rated torque, the unit of every torque hapticd sends, is now " +
             std::to_string(f.rated_after) + " mN m, not the " + std::to_string(f.rated_before) +
             " mN m hapticd scaled by: torque held at zero; fault clear takes the new unit";
  }
  return "";
}

}  // namespace hapticd::drivers::canopen
