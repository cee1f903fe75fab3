#include "drivers/canopen/402/homing.hpp"

namespace hapticd::drivers::canopen::cia402 {

namespace {

/// CiA 402-2 homing methods 1..37 by what they search (index pulse: the
/// encoder's zero mark after the switch).
struct MethodWords {
  std::int8_t first;
  std::int8_t last;
  std::string_view words;
};
constexpr MethodWords methods[] = {
    {1, 1, "on the negative limit switch and the index pulse"},
    {2, 2, "on the positive limit switch and the index pulse"},
    {3, 4, "on the positive home switch and the index pulse"},
    {5, 6, "on the negative home switch and the index pulse"},
    {7, 10, "on the home switch and the index pulse, positive initial motion"},
    {11, 14, "on the home switch and the index pulse, negative initial motion"},
    {17, 17, "on the negative limit switch"},
    {18, 18, "on the positive limit switch"},
    {19, 20, "on the positive home switch"},
    {21, 22, "on the negative home switch"},
    {23, 26, "on the home switch, positive initial motion"},
    {27, 30, "on the home switch, negative initial motion"},
    {33, 33, "on the index pulse, negative direction"},
    {34, 34, "on the index pulse, positive direction"},
    {35, 35, "on the current position (CiA 402 before v4; now 37)"},
    {37, 37, "on the current position"},
};

}  // namespace

HomingStatus decode_homing_status(std::uint16_t sw) noexcept {
  const bool error = (sw & homing_status_bit::error) != 0;
  const bool attained = (sw & homing_status_bit::attained) != 0;
  const bool reached = (sw & homing_status_bit::target_reached) != 0;
  if (error && attained) return HomingStatus::reserved;
  if (error) return reached ? HomingStatus::error_at_rest : HomingStatus::error_moving;
  if (attained) return reached ? HomingStatus::completed : HomingStatus::attained_target_not_reached;
  return reached ? HomingStatus::interrupted_or_not_started : HomingStatus::in_progress;
}

std::string_view to_string(HomingStatus status) noexcept {
  switch (status) {
    case HomingStatus::in_progress:
      return "homing in progress";
    case HomingStatus::interrupted_or_not_started:
      return "homing interrupted or not started";
    case HomingStatus::attained_target_not_reached:
      return "homing attained, target not reached";
    case HomingStatus::completed:
      return "homing completed";
    case HomingStatus::error_moving:
      return "homing error, velocity not 0";
    case HomingStatus::error_at_rest:
      return "homing error, velocity 0";
    case HomingStatus::reserved:
      return "reserved homing status (bits 13 and 12 both set)";
  }
  return "?";
}

std::string_view describe_homing_method(std::int8_t method) noexcept {
  if (method < 0) return "manufacturer-specific";
  for (const MethodWords& m : methods)
    if (method >= m.first && method <= m.last) return m.words;
  return "reserved (no CiA 402 method)";
}

bool homing_method_moves(std::int8_t method) noexcept { return method != 35 && method != 37; }

}  // namespace hapticd::drivers::canopen::cia402
