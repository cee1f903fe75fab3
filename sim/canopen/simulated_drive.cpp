#include "sim/canopen/simulated_drive.hpp"

#include <linux/can.h>
#include <linux/can/error.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "drivers/canopen/402/drive_errors.hpp"
#include "sim/canopen/sdo_server.hpp"

namespace hapticd::drivers::canopen::sim {

namespace {

constexpr int pdo_count = 4;
constexpr int max_mapped = 8;        ///< mapping entries per PDO in this drive
constexpr int max_pdo_bits = 64;     ///< a classic CAN frame's data
constexpr int consumer_entries = 4;  ///< 0x1016 sub-indices

/// The objects this drive has (CiA 301 7.5.2, CiA 402-2 6).
namespace object {
constexpr std::uint16_t device_type = 0x1000;
constexpr std::uint16_t error_register = 0x1001;
constexpr std::uint16_t consumer_heartbeat_time = 0x1016;
constexpr std::uint16_t producer_heartbeat_time = 0x1017;
constexpr std::uint16_t identity = 0x1018;
constexpr std::uint16_t error_behavior = 0x1029;
constexpr std::uint16_t abort_connection_option = 0x6007;
constexpr std::uint16_t error_code = 0x603F;
constexpr std::uint16_t controlword = 0x6040;
constexpr std::uint16_t statusword = 0x6041;
constexpr std::uint16_t quick_stop_option = 0x605A;
constexpr std::uint16_t modes_of_operation = 0x6060;
constexpr std::uint16_t modes_of_operation_display = 0x6061;
constexpr std::uint16_t position_actual = 0x6064;
constexpr std::uint16_t velocity_actual = 0x606C;
constexpr std::uint16_t target_torque = 0x6071;
constexpr std::uint16_t max_torque = 0x6072;
constexpr std::uint16_t rated_torque = 0x6076;
constexpr std::uint16_t torque_actual = 0x6077;
constexpr std::uint16_t interpolation_time_period = 0x60C2;
constexpr std::uint16_t supported_drive_modes = 0x6502;
constexpr std::uint16_t home_offset = 0x607C;
constexpr std::uint16_t homing_method = 0x6098;
constexpr std::uint16_t homing_speeds = 0x6099;
constexpr std::uint16_t homing_acceleration = 0x609A;
constexpr std::uint16_t digital_inputs = 0x60FD;
}  // namespace object

/// 0x6060 homing mode (CiA 402-2 6.3.2).
constexpr std::int8_t homing_mode = 6;
/// The velocity loop of the homing mode: its bandwidth, Hz.
constexpr double homing_loop_hz = 20.0;

/// 0x6060 cyclic synchronous torque (CiA 402-2 6.3.2).
constexpr std::int8_t cyclic_synchronous_torque = 10;

/// 0x6007 abort connection option codes (CiA 402-2 6.2.4).
namespace abort_connection {
constexpr std::int16_t no_action = 0;
constexpr std::int16_t fault_signal = 1;
constexpr std::int16_t disable_voltage = 2;
constexpr std::int16_t quick_stop = 3;
}  // namespace abort_connection

/// 0x1029:1 error behaviour on a communication error (CiA 301 7.5.2.32).
namespace error_behaviour {
constexpr std::uint32_t pre_operational = 0;
constexpr std::uint32_t stopped = 2;
}  // namespace error_behaviour

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

/// The 0x6502 bit of a 0x6060 mode: bit n - 1 for modes 1..10, none for the reserved 5.
std::optional<unsigned> supported_mode_bit(std::int8_t mode) {
  if (mode < 1 || mode > 10 || mode == 5) return std::nullopt;
  return static_cast<unsigned>(mode - 1);
}

}  // namespace

std::uint8_t error_register_for(std::uint16_t code) noexcept {
  namespace bit = error_register_bit;
  if (code == 0) return 0;
  std::uint8_t r = bit::generic;
  switch (code >> 12) {
    case 0x2:
      r |= bit::current;
      break;
    case 0x3:
      r |= bit::voltage;
      break;
    case 0x4:
      r |= bit::temperature;
      break;
    default:
      if ((code & 0xFF00U) == 0x8100U || (code & 0xFF00U) == 0x8200U) r |= bit::communication;
      break;
  }
  return r;
}

SimulatedDrive::SimulatedDrive(const DriveSettings& settings, DrivePlant& plant)
    : settings_(settings),
      plant_(plant),
      consumers_(consumer_entries),
      homing_(settings.limit_switches, settings.moving_mass * 2.0 * 3.141592653589793 * homing_loop_hz) {
  build_dictionary();
}

// ---- the object dictionary ---------------------------------------------------

void SimulatedDrive::build_dictionary() {
  using T = DataType;
  using A = Access;
  using M = PdoMapping;
  const DriveSettings& s = settings_;
  od_.add({object::device_type, 0}, T::unsigned32, A::ro, M::none, s.device_type);
  od_.add({object::error_register, 0}, T::unsigned8, A::ro, M::tpdo, 0);
  od_.add({object::consumer_heartbeat_time, 0}, T::unsigned8, A::ro, M::none, consumer_entries);
  for (int i = 1; i <= consumer_entries; ++i)
    od_.add({object::consumer_heartbeat_time, static_cast<std::uint8_t>(i)}, T::unsigned32, A::rw, M::none,
            0);
  od_.add({object::producer_heartbeat_time, 0}, T::unsigned16, A::rw, M::none, s.producer_heartbeat_ms);
  od_.add({object::identity, 0}, T::unsigned8, A::ro, M::none, 4);
  od_.add({object::identity, 1}, T::unsigned32, A::ro, M::none, s.vendor_id);
  od_.add({object::identity, 2}, T::unsigned32, A::ro, M::none, s.product_code);
  od_.add({object::identity, 3}, T::unsigned32, A::ro, M::none, s.revision);
  od_.add({object::identity, 4}, T::unsigned32, A::ro, M::none, s.serial);
  od_.add({object::error_behavior, 0}, T::unsigned8, A::ro, M::none, 1);
  od_.add({object::error_behavior, 1}, T::unsigned8, A::rw, M::none, error_behaviour::pre_operational);
  for (int p = 1; p <= pdo_count; ++p) add_pdo_parameters(p);
  od_.add({object::abort_connection_option, 0}, T::integer16, A::rw, M::none, abort_connection::no_action);
  od_.add({object::error_code, 0}, T::unsigned16, A::ro, M::tpdo, 0);
  od_.add({object::controlword, 0}, T::unsigned16, A::rw, M::rpdo, 0);
  od_.add({object::statusword, 0}, T::unsigned16, A::ro, M::tpdo, 0);
  od_.add({object::quick_stop_option, 0}, T::integer16, A::rw, M::none, 2);  // quick stop ramp, then disabled
  od_.add({object::modes_of_operation, 0}, T::integer8, A::rw, M::rpdo, 0);
  od_.add({object::modes_of_operation_display, 0}, T::integer8, A::ro, M::tpdo, 0);
  od_.add({object::position_actual, 0}, T::integer32, A::ro, M::tpdo, 0);
  od_.add({object::velocity_actual, 0}, T::integer32, A::ro, M::tpdo, 0);
  od_.add({object::target_torque, 0}, T::integer16, A::rw, M::rpdo, 0);
  od_.add({object::max_torque, 0}, T::unsigned16, A::rw, M::rpdo, 3000);  // 300 % of rated
  od_.add({object::rated_torque, 0}, T::unsigned32, A::rw, M::none, s.rated_torque_mnm);
  od_.add({object::torque_actual, 0}, T::integer16, A::ro, M::tpdo, 0);
  od_.add({object::interpolation_time_period, 0}, T::unsigned8, A::ro, M::none, 2);
  od_.add({object::interpolation_time_period, 1}, T::unsigned8, A::rw, M::none, 1);
  od_.add({object::interpolation_time_period, 2}, T::integer8, A::rw, M::none, 0xFD);  // 1 x 10^-3 s
  od_.add({object::supported_drive_modes, 0}, T::unsigned32, A::ro, M::none, s.supported_modes);
  // Homing (CiA 402-2 6.6): defaults of 0.5 and 0.1 per second and 5 per second squared of the unit.
  const double v = s.velocity_units_per_si;
  od_.add({object::home_offset, 0}, T::integer32, A::rw, M::rpdo, 0);
  od_.add({object::homing_method, 0}, T::integer8, A::rw, M::rpdo, 37);
  od_.add({object::homing_speeds, 0}, T::unsigned8, A::ro, M::none, 2);
  od_.add({object::homing_speeds, 1}, T::unsigned32, A::rw, M::rpdo,
          static_cast<std::uint32_t>(std::lround(0.5 * v)));
  od_.add({object::homing_speeds, 2}, T::unsigned32, A::rw, M::rpdo,
          static_cast<std::uint32_t>(std::lround(0.1 * v)));
  od_.add({object::homing_acceleration, 0}, T::unsigned32, A::rw, M::rpdo,
          static_cast<std::uint32_t>(std::lround(5.0 * v)));
  od_.add({object::digital_inputs, 0}, T::unsigned32, A::ro, M::tpdo, 0);
}

void SimulatedDrive::add_pdo_parameters(int p) {
  using T = DataType;
  using A = Access;
  using M = PdoMapping;
  const std::uint8_t n = settings_.node_id;
  // Factory defaults as many drives ship them: RPDO1 = controlword and
  // TPDO1 = statusword, event-driven; the others not valid.
  const bool first = p == 1;
  const std::uint16_t rc = communication_index(Direction::receive, p);
  const std::uint16_t tc = communication_index(Direction::transmit, p);
  od_.add({rc, 0}, T::unsigned8, A::ro, M::none, 2);
  od_.add({rc, 1}, T::unsigned32, A::rw, M::none, pdo_cob_id_word(default_rpdo_id(p, n), first));
  od_.add({rc, 2}, T::unsigned8, A::rw, M::none, transmission::event_profile);
  od_.add({tc, 0}, T::unsigned8, A::ro, M::none, 5);
  od_.add({tc, 1}, T::unsigned32, A::rw, M::none, pdo_cob_id_word(default_tpdo_id(p, n), first));
  od_.add({tc, 2}, T::unsigned8, A::rw, M::none, transmission::event_profile);
  od_.add({tc, 3}, T::unsigned16, A::rw, M::none, 0);  // inhibit time
  od_.add({tc, 5}, T::unsigned16, A::rw, M::none, 0);  // event timer
  const std::uint16_t rm = mapping_index(Direction::receive, p);
  const std::uint16_t tm = mapping_index(Direction::transmit, p);
  od_.add({rm, 0}, T::unsigned8, A::rw, M::none, first ? 1 : 0);
  od_.add({tm, 0}, T::unsigned8, A::rw, M::none, first ? 1 : 0);
  for (int sub = 1; sub <= max_mapped; ++sub) {
    const bool mapped = first && sub == 1;
    const auto s = static_cast<std::uint8_t>(sub);
    od_.add({rm, s}, T::unsigned32, A::rw, M::none, mapped ? mapping_word(object::controlword, 0, 16) : 0);
    od_.add({tm, s}, T::unsigned32, A::rw, M::none, mapped ? mapping_word(object::statusword, 0, 16) : 0);
  }
}

std::uint16_t SimulatedDrive::communication_index(Direction d, int number) noexcept {
  return static_cast<std::uint16_t>((d == Direction::receive ? 0x1400 : 0x1800) + number - 1);
}

std::uint16_t SimulatedDrive::mapping_index(Direction d, int number) noexcept {
  return static_cast<std::uint16_t>((d == Direction::receive ? 0x1600 : 0x1A00) + number - 1);
}

PdoCobId SimulatedDrive::cob_id(Direction d, int number) const {
  return pdo_cob_id(od_.get({communication_index(d, number), 1}));
}

ConsumerEntry SimulatedDrive::consumer(int i) const {
  return consumer_entry(od_.get({object::consumer_heartbeat_time, static_cast<std::uint8_t>(i + 1)}));
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
  if (!mute_) out.push_back(heartbeat(settings_.node_id, NmtState::boot_up));
  enter_nmt(NmtState::pre_operational, now);
}

void SimulatedDrive::enter_nmt(NmtState state, Micros now) {
  // The heartbeat producer starts one period after the boot-up message.
  if (nmt_ == NmtState::boot_up)
    next_heartbeat_ = now + Micros(std::chrono::milliseconds(od_.get({object::producer_heartbeat_time, 0})));
  nmt_ = state;
}

void SimulatedDrive::on_nmt(NmtCommand command, Micros now, std::vector<Frame>& out) {
  switch (command) {
    case NmtCommand::start_remote_node:
      enter_nmt(NmtState::operational, now);
      break;
    case NmtCommand::stop_remote_node:
      lost_master(0, "NMT stop while enabled", out);
      enter_nmt(NmtState::stopped, now);
      break;
    case NmtCommand::enter_pre_operational:
      enter_nmt(NmtState::pre_operational, now);
      break;
    case NmtCommand::reset_node:
      od_.reset(0x0000, 0xFFFF);
      homing_ = HomingController(settings_.limit_switches, homing_.gain());
      home_shift_counts_ = 0;  // the application's reset: the homing is lost
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
  if (mute_ || !powered_ || !is_data_frame(frame)) return;
  finish_fault_reaction();  // the reaction (power stage off) is over by the next frame
  const std::uint8_t node = settings_.node_id;
  if (const auto nmt = parse_nmt(frame)) {
    if (nmt->node == 0 || nmt->node == node) on_nmt(nmt->command, now, out);
    return;
  }
  // Stopped: only NMT and error control (CiA 301 7.3.2.2.1).
  const auto hb = parse_heartbeat(frame);
  if (nmt_ == NmtState::stopped) {
    if (hb) on_heartbeat(*hb, now);
    return;
  }
  if (is_sync(frame)) {
    on_sync(out);
    return;
  }
  if (frame.id == can_id(function_code::sdo_client_to_server, node)) {
    on_sdo(frame, out);
    return;
  }
  if (hb) {
    on_heartbeat(*hb, now);
    return;
  }
  if (nmt_ != NmtState::operational) return;  // PDOs only while operational
  for (int p = 1; p <= pdo_count; ++p) {
    const PdoCobId id = cob_id(Direction::receive, p);
    if (id.valid && id.can_id == frame.id) {
      on_rpdo(p, frame, out);
      return;
    }
  }
}

void SimulatedDrive::tick(Micros now, std::vector<Frame>& out) {
  if (mute_ || !powered_) return;
  finish_fault_reaction();
  const auto period_ms = static_cast<std::uint16_t>(od_.get({object::producer_heartbeat_time, 0}));
  if (period_ms != 0 && now >= next_heartbeat_) {
    out.push_back(heartbeat(settings_.node_id, nmt_));
    ++counters_.heartbeats_sent;
    const Micros period = std::chrono::milliseconds(period_ms);
    next_heartbeat_ += period;
    if (next_heartbeat_ <= now) next_heartbeat_ = now + period;  // late: do not burst
  }
  watch_consumers(now, out);
}

void SimulatedDrive::watch_consumers(Micros now, std::vector<Frame>& out) {
  for (int i = 0; i < consumer_entries; ++i) {
    Consumer& c = consumers_[static_cast<std::size_t>(i)];
    const ConsumerEntry entry = consumer(i);
    if (!entry.used() || !c.active) continue;
    if (now - c.last > Micros(std::chrono::milliseconds(entry.time_ms))) {
      c.active = false;  // monitoring restarts with the next heartbeat
      ++counters_.heartbeat_timeouts;
      lost_master(error_code::heartbeat,
                  "heartbeat of node " + std::to_string(entry.node) + " lost (consumer time " +
                      std::to_string(entry.time_ms) + " ms)",
                  out);
    }
  }
}

Micros SimulatedDrive::next_deadline() const noexcept {
  Micros next = Micros::max();
  if (od_.get({object::producer_heartbeat_time, 0}) != 0) next = next_heartbeat_;
  for (int i = 0; i < consumer_entries; ++i) {
    const Consumer& c = consumers_[static_cast<std::size_t>(i)];
    const ConsumerEntry entry = consumer(i);
    if (entry.used() && c.active)
      next = std::min(next, c.last + Micros(std::chrono::milliseconds(entry.time_ms)) + Micros(1));
  }
  return next;
}

void SimulatedDrive::on_heartbeat(const Heartbeat& hb, Micros now) {
  for (int i = 0; i < consumer_entries; ++i) {
    const ConsumerEntry entry = consumer(i);
    if (!entry.used() || entry.node != hb.node) continue;
    // Monitoring starts with the first heartbeat, not the boot-up (CiA 301 7.2.8.3.2.2).
    consumers_[static_cast<std::size_t>(i)].active = hb.state != NmtState::boot_up;
    consumers_[static_cast<std::size_t>(i)].last = now;
  }
}

// ---- SDO server --------------------------------------------------------------

void SimulatedDrive::on_sdo(const Frame& frame, std::vector<Frame>& out) {
  const std::uint8_t node = settings_.node_id;
  const auto request = parse_sdo_request(frame);
  if (!request) return;
  ++counters_.sdo_requests;
  using Kind = SdoRequest::Kind;
  if (request->kind == Kind::client_abort) return;  // nothing in progress in an expedited-only server
  auto abort = [&](std::uint32_t code) {
    ++counters_.sdo_aborts;
    out.push_back(abort_response(node, request->address, code));
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
      out.push_back(upload_response(node, request->address, e->value, bytes_of(e->type)));
      return;
    }
    case Kind::expedited_download: {
      if (const std::uint32_t code = sdo_download(request->address, request->data, request->size))
        return abort(code);
      out.push_back(download_response(node, request->address));
      if (request->address == Address{object::controlword, 0})
        on_controlword(static_cast<std::uint16_t>(request->data), out);
      return;
    }
    case Kind::segmented_or_block:
    case Kind::unknown:
    case Kind::client_abort:
      return abort(abort_code::unknown_command);
  }
}

std::uint32_t SimulatedDrive::sdo_download(Address address, std::uint32_t value, std::uint8_t size) {
  if (const std::uint32_t code = od_.check_write(address, size)) return code;
  if (const std::uint32_t code = check_pdo_write(address, value)) return code;
  if (const std::uint32_t code = check_drive_write(address, value)) return code;
  od_.set(address, value);
  after_write(address);
  return 0;
}

std::uint32_t SimulatedDrive::check_pdo_write(Address a, std::uint32_t value) const {
  for (int p = 1; p <= pdo_count; ++p) {
    for (const Direction d : {Direction::receive, Direction::transmit}) {
      if (a.index == mapping_index(d, p)) return check_mapping_write(d, p, a, value);
      if (a.index != communication_index(d, p)) continue;
      if (a.sub == 1) {
        const PdoCobId next = pdo_cob_id(value);
        const PdoCobId current = cob_id(d, p);
        if (next.extended || next.upper_bits != 0) return abort_code::invalid_value;  // 29-bit: not supported
        if (next.valid && current.valid && next.can_id != current.can_id) return abort_code::invalid_value;
        if (next.valid && (restricted_can_id(next.can_id) || od_.get({mapping_index(d, p), 0}) == 0))
          return abort_code::invalid_value;
      }
      if (a.sub == 2 && !synchronous(static_cast<std::uint8_t>(value)) &&
          value < transmission::event_manufacturer)
        return abort_code::invalid_value;  // reserved, or RTR-only
      return 0;
    }
  }
  return 0;
}

std::uint32_t SimulatedDrive::check_mapping_write(Direction d, int number, Address a,
                                                  std::uint32_t value) const {
  // The mapping changes only while the PDO is not valid, and its entries only while the count is 0.
  const std::uint16_t map = mapping_index(d, number);
  if (cob_id(d, number).valid || (a.sub != 0 && od_.get({map, 0}) != 0)) return abort_code::wrong_state;
  const PdoMapping wanted = d == Direction::receive ? PdoMapping::rpdo : PdoMapping::tpdo;
  auto mappable = [&](std::uint32_t word) {
    const MappedObject m = mapped_object(word);
    const Entry* target = od_.find({m.index, m.sub});
    return target != nullptr && target->mapping == wanted && m.bits == 8U * bytes_of(target->type);
  };
  if (a.sub != 0) return value == 0 || mappable(value) ? 0 : abort_code::not_mappable;
  if (value > max_mapped) return abort_code::mapping_too_long;
  std::uint32_t bits = 0;
  for (std::uint32_t s = 1; s <= value; ++s) {
    const std::uint32_t word = od_.get({map, static_cast<std::uint8_t>(s)});
    if (!mappable(word)) return abort_code::not_mappable;
    bits += mapped_object(word).bits;
  }
  return bits > max_pdo_bits ? abort_code::mapping_too_long : 0;
}

std::uint32_t SimulatedDrive::check_drive_write(Address a, std::uint32_t value) const {
  if (a == Address{object::modes_of_operation, 0}) {
    const auto mode = static_cast<std::int8_t>(value & 0xFFU);
    if (mode == 0) return 0;
    const auto bit = supported_mode_bit(mode);
    const std::uint32_t supported = od_.get({object::supported_drive_modes, 0});
    return bit && (supported >> *bit & 1U) != 0 ? 0 : abort_code::invalid_value;
  }
  if (a == Address{object::homing_method, 0})
    return homing_.has_method(static_cast<std::int8_t>(value & 0xFFU)) ? 0 : abort_code::invalid_value;
  if (a == Address{object::abort_connection_option, 0}) {
    const auto option = static_cast<std::int16_t>(value & 0xFFFFU);
    return option >= abort_connection::no_action && option <= abort_connection::quick_stop
               ? 0
               : abort_code::invalid_value;
  }
  if (a == Address{object::error_behavior, 1}) return value <= 2 ? 0 : abort_code::invalid_value;
  if (a.index == object::consumer_heartbeat_time && a.sub >= 1) {
    const ConsumerEntry next = consumer_entry(value);
    if (next.reserved != 0) return abort_code::invalid_value;
    if (!next.used()) return 0;
    for (int i = 0; i < consumer_entries; ++i) {
      if (i + 1 == a.sub) continue;
      const ConsumerEntry other = consumer(i);
      if (other.used() && other.node == next.node) return abort_code::parameter_incompatible;
    }
  }
  return 0;
}

void SimulatedDrive::after_write(Address a) {
  if (a == Address{object::modes_of_operation, 0} && !refuse_mode_)
    od_.set({object::modes_of_operation_display, 0}, od_.get(a));
  if (a.index == object::consumer_heartbeat_time && a.sub >= 1 && a.sub <= consumer_entries)
    consumers_[a.sub - 1U] = Consumer{};
  if (a == Address{object::producer_heartbeat_time, 0}) next_heartbeat_ = Micros{0};  // due at the next tick
}

void SimulatedDrive::abort_next_sdo(std::optional<Address> address, std::uint32_t code) noexcept {
  abort_pending_ = true;
  abort_address_ = address;
  abort_code_ = code;
}

// ---- PDOs and SYNC -----------------------------------------------------------

std::optional<SimulatedDrive::PdoLayout> SimulatedDrive::layout(Direction d, int number) const {
  const std::uint16_t map = mapping_index(d, number);
  PdoLayout l;
  l.count = static_cast<int>(std::min<std::uint32_t>(od_.get({map, 0}), max_mapped));
  int offset = 0;
  for (int i = 0; i < l.count; ++i) {
    const MappedObject m = mapped_object(od_.get({map, static_cast<std::uint8_t>(i + 1)}));
    if (m.bits % 8 != 0 || offset + m.bits / 8 > max_pdo_bits / 8)
      return std::nullopt;  // writes were checked
    l.objects[i] = {m.index, m.sub};
    l.bytes[i] = static_cast<std::uint8_t>(m.bits / 8);
    l.offsets[i] = static_cast<std::uint8_t>(offset);
    offset += m.bits / 8;
  }
  l.length = static_cast<std::uint8_t>(offset);
  return l;
}

void SimulatedDrive::on_rpdo(int number, const Frame& frame, std::vector<Frame>& out) {
  ++counters_.rpdos_received;
  const auto l = layout(Direction::receive, number);
  if (!l || frame.len < l->length) {  // CiA 301: not processed, EMCY 0x8210
    ++counters_.rpdo_length_errors;
    send_emcy(error_code::pdo_length, error_register_for(error_code::pdo_length), out);
    return;
  }
  const auto type = static_cast<std::uint8_t>(od_.get({communication_index(Direction::receive, number), 2}));
  if (synchronous(type)) {
    rpdo_[number - 1] = RxPdoBuffer{true, frame};  // takes effect at the next SYNC
  } else {
    apply_rpdo(number, frame, out);
  }
}

void SimulatedDrive::apply_rpdo(int number, const Frame& frame, std::vector<Frame>& out) {
  const auto l = layout(Direction::receive, number);
  if (!l || frame.len < l->length) return;
  for (int i = 0; i < l->count; ++i) {
    const Address a = l->objects[i];
    const std::uint32_t value = get_le(frame, l->offsets[i], l->bytes[i]);
    if (a == Address{object::controlword, 0}) {
      on_controlword(static_cast<std::uint16_t>(value), out);
    } else {
      od_.set(a, value);
      if (a == Address{object::modes_of_operation, 0} && !refuse_mode_)
        od_.set({object::modes_of_operation_display, 0}, value);
    }
  }
}

void SimulatedDrive::on_sync(std::vector<Frame>& out) {
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
  // Quick stop in torque mode: the torque is zero at once, so the quick stop
  // is done: transition 12 for the 0x605A codes 0..4; 5..8 stay in Quick Stop Active.
  const auto option = static_cast<std::int16_t>(od_.get({object::quick_stop_option, 0}));
  if (state_ == DriveState::quick_stop_active && (option < 5 || option > 8))
    state_ = DriveState::switch_on_disabled;
  const double force = mode_display() == homing_mode ? homing_force() : torque_to_apply();
  applied_force_ = force;
  if (nmt_ == NmtState::operational) send_tpdos(out);
  plant_.step(force);
}

double SimulatedDrive::torque_to_apply() const {
  const bool halt = (controlword_ & halt_bit) != 0;
  if (state_ != DriveState::operation_enabled || halt || mode_display() != cyclic_synchronous_torque)
    return 0.0;
  const auto target = static_cast<std::int16_t>(od_.get({object::target_torque, 0}));
  const auto limit = static_cast<int>(od_.get({object::max_torque, 0}));
  const int permille = std::clamp<int>(target, -limit, limit);  // 0x6071 and 0x6072: per mille of 0x6076
  return permille * 1e-3 * od_.get({object::rated_torque, 0}) * 1e-3;
}

double SimulatedDrive::homing_force() {
  if (state_ != DriveState::operation_enabled) {
    homing_.interrupt();
    return 0.0;
  }
  const double v_units = settings_.velocity_units_per_si;
  HomingObjects o;
  o.method = static_cast<std::int8_t>(od_.get({object::homing_method, 0}) & 0xFFU);
  o.speed_switch = od_.get({object::homing_speeds, 1}) / v_units;
  o.speed_zero = od_.get({object::homing_speeds, 2}) / v_units;
  o.acceleration = od_.get({object::homing_acceleration, 0}) / v_units;
  o.max_force = od_.get({object::max_torque, 0}) * 1e-3 * od_.get({object::rated_torque, 0}) * 1e-3;
  const double force = homing_.step(plant_.position(), plant_.velocity(), o, settings_.period_s);
  if (const auto home = homing_.take_home()) {
    // CiA 402: the zero lies the home offset past the home, so the home reads -0x607C.
    const auto offset = static_cast<std::int32_t>(od_.get({object::home_offset, 0}));
    const std::int64_t at_home =
        std::llround(*home * settings_.position_units_per_si) + position_offset_counts_;
    home_shift_counts_ = -static_cast<std::int64_t>(offset) - at_home;
  }
  return force;
}

std::int64_t SimulatedDrive::position_counts() const {
  return std::llround(plant_.position() * settings_.position_units_per_si) + position_offset_counts_;
}

void SimulatedDrive::send_tpdos(std::vector<Frame>& out) {
  refresh_process_values();
  for (int p = 1; p <= pdo_count; ++p) {
    const PdoCobId id = cob_id(Direction::transmit, p);
    const auto type = static_cast<std::uint8_t>(od_.get({communication_index(Direction::transmit, p), 2}));
    if (!id.valid || !synchronous(type)) continue;
    const std::uint8_t every = type == 0 ? 1 : type;
    if (++tpdo_sync_count_[p - 1] < every) continue;
    tpdo_sync_count_[p - 1] = 0;
    const auto l = layout(Direction::transmit, p);
    if (!l || l->count == 0) continue;
    if (drop_tpdos_ != 0) {
      if (drop_tpdos_ > 0) --drop_tpdos_;
      ++counters_.tpdos_dropped;
      continue;
    }
    Frame f;
    f.id = id.can_id;
    f.len = l->length;
    for (int i = 0; i < l->count; ++i) put_le(f, l->offsets[i], od_.get(l->objects[i]), l->bytes[i]);
    out.push_back(f);
    ++counters_.tpdos_sent;
  }
}

void SimulatedDrive::refresh_process_values() {
  od_.set({object::statusword, 0}, statusword());
  // INTEGER32 wraps like a drive's counter.
  od_.set({object::position_actual, 0},
          static_cast<std::uint32_t>(static_cast<std::uint64_t>(position_counts() + home_shift_counts_)));
  od_.set({object::digital_inputs, 0}, homing_.digital_inputs(plant_.position()));
  od_.set({object::velocity_actual, 0}, to_int32_units(plant_.velocity() * settings_.velocity_units_per_si));
  const double rated_nm = od_.get({object::rated_torque, 0}) * 1e-3;
  const double permille = rated_nm > 0.0 ? applied_force_ / rated_nm * 1e3 : 0.0;
  od_.set({object::torque_actual, 0},
          static_cast<std::uint16_t>(static_cast<std::int16_t>(std::lround(permille))));
}

// ---- CiA 402 state machine ---------------------------------------------------

void SimulatedDrive::on_controlword(std::uint16_t cw, std::vector<Frame>& out) {
  const auto command = control_command(controlword_, cw);
  const DriveState before = state_;
  if (command)
    state_ =
        after_command(state_, *command, static_cast<std::int16_t>(od_.get({object::quick_stop_option, 0})));
  if (mode_display() == homing_mode && state_ == DriveState::operation_enabled) {
    homing_.on_controlword(controlword_, cw, plant_.position());
  } else {
    homing_.interrupt();
  }
  controlword_ = cw;
  od_.set({object::controlword, 0}, cw);
  if (before == DriveState::fault && state_ == DriveState::switch_on_disabled) {
    // Transition 15: the error is reset, and said so with the EMCY "error reset" (code 0x0000).
    od_.set({object::error_code, 0}, 0);
    od_.set({object::error_register, 0}, 0);
    fault_reason_.clear();
    send_emcy(error_code::error_reset, 0, out);
  }
}

std::uint16_t SimulatedDrive::statusword() const noexcept {
  std::uint16_t sw = state_statusword(state_);
  if (state_ != DriveState::not_ready_to_switch_on) sw |= status_bit::voltage_enabled;
  sw |= status_bit::remote;
  if (state_ == DriveState::operation_enabled && (controlword_ & halt_bit) == 0 &&
      mode_display() == cyclic_synchronous_torque)
    sw |= status_bit::following_command;
  if (mode_display() == homing_mode) sw |= homing_.status_bits(plant_.velocity());
  return sw;
}

std::int8_t SimulatedDrive::mode_display() const noexcept {
  return static_cast<std::int8_t>(od_.get({object::modes_of_operation_display, 0}) & 0xFFU);
}

std::uint16_t SimulatedDrive::error_code() const noexcept {
  return static_cast<std::uint16_t>(od_.get({object::error_code, 0}));
}

void SimulatedDrive::send_emcy(std::uint16_t code, std::uint8_t error_register, std::vector<Frame>& out) {
  if (mute_) return;
  out.push_back(emergency(settings_.node_id, code, error_register));
  ++counters_.emcys_sent;
}

void SimulatedDrive::fault(std::uint16_t code, std::uint8_t error_register, const std::string& reason,
                           std::vector<Frame>& out) {
  od_.set({object::error_code, 0}, code);
  od_.set({object::error_register, 0}, error_register);
  fault_reason_ = reason.empty() ? cia402::describe_error_code(code) : reason;
  // Transition 13: the power stage is off from here.
  if (state_ != DriveState::fault) state_ = DriveState::fault_reaction_active;
  applied_force_ = 0.0;
  send_emcy(code, error_register, out);
}

void SimulatedDrive::finish_fault_reaction() {
  if (state_ == DriveState::fault_reaction_active) state_ = DriveState::fault;  // transition 14
}

void SimulatedDrive::lost_master(std::uint16_t emcy_code, const std::string& reason,
                                 std::vector<Frame>& out) {
  const auto option = static_cast<std::int16_t>(od_.get({object::abort_connection_option, 0}));
  const bool enabled = state_ == DriveState::operation_enabled;
  const std::uint8_t reg = error_register_for(emcy_code);
  const auto quick_stop_option = static_cast<std::int16_t>(od_.get({object::quick_stop_option, 0}));
  if (option == abort_connection::fault_signal && enabled) {
    fault(emcy_code == 0 ? error_code::generic : emcy_code, reg == 0 ? error_register_bit::generic : reg,
          reason, out);
  } else {
    if (emcy_code != 0) send_emcy(emcy_code, reg, out);
    if (option == abort_connection::disable_voltage)
      state_ = after_command(state_, ControlCommand::disable_voltage, quick_stop_option);
    if (option == abort_connection::quick_stop)
      state_ = after_command(state_, ControlCommand::quick_stop, quick_stop_option);
  }
  // 0x1029: a communication error takes an operational node to pre-operational (0), keeps it (1), or
  // stops it (2).
  if (emcy_code == error_code::heartbeat && nmt_ == NmtState::operational) {
    const std::uint32_t behaviour = od_.get({object::error_behavior, 1});
    if (behaviour == error_behaviour::pre_operational) nmt_ = NmtState::pre_operational;
    if (behaviour == error_behaviour::stopped) nmt_ = NmtState::stopped;
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
  error.len = CAN_ERR_DLC;
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
