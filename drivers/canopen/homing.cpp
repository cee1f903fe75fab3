#include "drivers/canopen/homing.hpp"

#include <cmath>

#include "drivers/canopen/402/objects.hpp"
#include "drivers/canopen/drive_setup.hpp"
#include "world/text.hpp"

namespace hapticd::drivers::canopen {

using cia301::ObjectAddress;
using cia402::HomingStatus;
namespace obj402 = cia402::object;

namespace {

/// 0x6502 bit 5: homing mode (bit n - 1 for mode n).
constexpr unsigned homing_mode_bit = 5;

std::string homing_node(std::uint8_t node) { return "node " + std::to_string(node); }

/// One homing object: a refusal names `key`; a missing object is noted
/// when the homing can do without it (`needed` false).
void write_homing_object(SdoClient& sdo, ObjectAddress address, std::uint32_t value, std::uint8_t size,
                         const std::string& key, bool needed, const std::string& role,
                         std::vector<std::string>& notes) {
  try {
    sdo.write(address, value, size);
  } catch (const SdoError& e) {
    if (e.object_missing() && !needed) {
      notes.push_back("no " + world::text::format_hex(address.index, 4) + " " + role + ": the drive's own");
      return;
    }
    throw SetupError(std::string(e.what()) + ": CiA 402 " + role + " (" + key + ")", key);
  }
}

void check_homing_offered(SdoClient& sdo) {
  std::uint32_t modes = 0;
  try {
    modes = sdo.read({obj402::supported_drive_modes, 0});
  } catch (const SdoError& e) {
    if (e.object_missing()) return;  // confirmed by 0x6061 alone
    throw SetupError(e.what(), "homing");
  }
  if ((modes >> homing_mode_bit & 1U) == 0)
    throw SetupError(homing_node(sdo.node()) +
                         " does not offer homing mode: 0x6502 supported drive modes = " +
                         world::text::format_hex(modes, 8) + " (bit 5 clear); set homing = \"none\"",
                     "homing");
}

}  // namespace

void prepare_homing(SdoClient& sdo, const HomingSettings& s, std::vector<std::string>& notes) {
  check_homing_offered(sdo);
  const bool moves = cia402::homing_method_moves(s.method);
  write_homing_object(sdo, {obj402::homing_method, 0}, static_cast<std::uint8_t>(s.method), 1,
                      "homing_method", true,
                      "0x6098 homing method " + std::to_string(s.method) + " (" +
                          std::string(cia402::describe_homing_method(s.method)) + ")",
                      notes);
  write_homing_object(sdo, {obj402::home_offset, 0}, static_cast<std::uint32_t>(s.home_offset_counts), 4,
                      "home_offset", s.home_offset_counts != 0, "home offset", notes);
  if (s.speed_switch)
    write_homing_object(sdo, {obj402::homing_speeds, cia402::homing_speed_sub::switch_search},
                        *s.speed_switch, 4, "homing_speed_switch", moves,
                        "homing speed during the search for the switch", notes);
  if (s.speed_zero)
    write_homing_object(sdo, {obj402::homing_speeds, cia402::homing_speed_sub::zero_search}, *s.speed_zero, 4,
                        "homing_speed_zero", moves, "homing speed during the search for zero", notes);
  if (s.acceleration)
    write_homing_object(sdo, {obj402::homing_acceleration, 0}, *s.acceleration, 4, "homing_acceleration",
                        moves, "homing acceleration", notes);
  select_mode(sdo, cia402::Mode::homing, "homing", "homing");
}

HomingPhase HomingSequence::step(const HomingObservation& seen) noexcept {
  if (done()) return phase_;
  statusword_ = seen.statusword;
  ++periods_;
  if (seen.faulted) {
    fail(HomingFailure::drive_fault);
    return phase_;
  }
  if (phase_ == HomingPhase::enabling) {
    if (seen.operational) {
      phase_ = HomingPhase::starting;  // bit 4 goes out in this period's RPDO
      tpdos_at_start_ = seen.tpdos;
      periods_ = 0;
    } else if (periods_ > enable_periods_) {
      fail(HomingFailure::not_enabled);
    }
    return phase_;
  }
  ++homing_;
  if (!seen.operational) {
    fail(HomingFailure::drive_fault);  // it left Operation Enabled
    return phase_;
  }
  if (phase_ == HomingPhase::starting && seen.tpdos >= tpdos_at_start_ + tpdos_after_start)
    phase_ = HomingPhase::homing;
  if (phase_ == HomingPhase::homing) judge(seen);
  if (!done() && homing_ > homing_periods_) fail(HomingFailure::timed_out);
  return phase_;
}

void HomingSequence::judge(const HomingObservation& seen) noexcept {
  status_ = cia402::decode_homing_status(seen.statusword);
  switch (status_) {
    case HomingStatus::in_progress:
    case HomingStatus::attained_target_not_reached:
      progress_seen_ = true;
      break;
    case HomingStatus::completed:
      phase_ = HomingPhase::completed;
      break;
    case HomingStatus::interrupted_or_not_started:
      if (progress_seen_) fail(HomingFailure::interrupted);  // else: not started yet
      break;
    case HomingStatus::error_moving:
    case HomingStatus::error_at_rest:
      fail(HomingFailure::homing_error);
      break;
    case HomingStatus::reserved:
      fail(HomingFailure::reserved_status);
      break;
  }
}

HomingVerdict describe(const HomingSequence& q, std::uint8_t node, std::int8_t method, double period_s) {
  const std::string who = homing_node(node) + " homing method " + std::to_string(method) + " (" +
                          std::string(cia402::describe_homing_method(method)) + ")";
  const std::string status = "statusword " + world::text::format_hex(q.last_statusword(), 4) + ": " +
                             std::string(cia402::to_string(q.last_status()));
  const std::string after = " after " + std::to_string(q.homing_periods()) + " periods (" +
                            world::text::format_number(static_cast<double>(q.homing_periods()) * period_s) +
                            " s)";
  switch (q.failure()) {
    case HomingFailure::none:
      return {};
    case HomingFailure::not_enabled:
      return {homing_node(node) + " did not reach Operation Enabled in homing mode: statusword " +
                  world::text::format_hex(q.last_statusword(), 4),
              "homing"};
    case HomingFailure::drive_fault:
      return {who + " stopped by the drive" + after, "homing"};
    case HomingFailure::homing_error:
      return {who + ": the drive reports a homing error" + after + ", " + status +
                  "; check the method against the drive's switches and wiring",
              "homing_method"};
    case HomingFailure::interrupted:
      return {who + " was interrupted by the drive" + after + ", " + status, "homing_method"};
    case HomingFailure::reserved_status:
      return {who + ": the drive shows a reserved homing status, " + status, "homing"};
    case HomingFailure::timed_out:
      return {who + " did not complete" + after + " (homing_timeout); the last " + status, "homing_timeout"};
  }
  return {};
}

}  // namespace hapticd::drivers::canopen
