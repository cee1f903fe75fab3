#include "daemon/engine/safety.hpp"

#include <cstdio>
#include <numbers>

namespace hapticd::daemon::engine {

std::string_view to_string(FaultReason reason) noexcept {
  switch (reason) {
    case FaultReason::none:
      return "none";
    case FaultReason::estop:
      return "estop";
    case FaultReason::non_finite_position:
      return "non-finite position from the device";
    case FaultReason::non_finite_command:
      return "non-finite command from the scene";
    case FaultReason::device_fault:
      return "device fault";
    case FaultReason::read_error_streak:
      return "read error streak";
    case FaultReason::write_error:
      return "write error";
    case FaultReason::overrun_streak:
      return "overrun streak";
    case FaultReason::encoder_jump:
      return "encoder jump / velocity limit";
    case FaultReason::kinematics:
      return "kinematics: out of the workspace (the linkage cannot close at these joint angles)";
    case FaultReason::kinematics_singular:
      return "kinematics: at a singular configuration of the linkage (no force can be rendered there)";
  }
  return "unknown";
}

double default_max_velocity(bool rotary, double mass, double torque_limit) noexcept {
  // docs/config.md gives the reasoning and the figures for each shipped device.
  const double hand = rotary ? 50.0 : 5.0;                      // rad/s, m/s
  const double travel = rotary ? 2.0 * std::numbers::pi : 0.1;  // one turn, a desk workspace
  if (!(mass > 0.0) || !std::isfinite(mass) || !(torque_limit > 0.0)) return hand;
  return hand + std::sqrt(2.0 * torque_limit * travel / mass);
}

std::string describe_rule(const PositionStepRule& rule, bool configured) {
  if (!rule.enabled()) return "no position-step check";
  const char* unit = rule.rotary ? "rad" : "m";
  const double limit = rule.step_limit(rule.period_s);
  char counts[48] = "";
  if (rule.resolution > 0.0) std::snprintf(counts, sizeof counts, " (%.4g counts)", limit / rule.resolution);
  char text[320];
  std::snprintf(
      text, sizeof text,
      "max_velocity %.6g %s/s (%s), a position step over %.6g %s%s in one period of %.6g ms latches "
      "\"%s\"",
      rule.max_velocity, unit, configured ? "device.max_velocity" : "derived from the device", limit, unit,
      counts, rule.period_s * 1e3, std::string(to_string(FaultReason::encoder_jump)).c_str());
  return text;
}

std::string describe(const PositionJump& jump, const PositionStepRule& rule) {
  const char* unit = rule.rotary ? "rad" : "m";
  char counts[64] = "";
  char count[64] = "";
  if (rule.resolution > 0.0) {
    std::snprintf(counts, sizeof counts, " (%+.10g counts)", jump.step / rule.resolution);
    std::snprintf(count, sizeof count, " + 1 count of %.6g %s", rule.resolution, unit);
  }
  char axis[32] = "";
  if (jump.axis >= 0) std::snprintf(axis, sizeof axis, " (axis %d)", jump.axis + 1);
  char text[416];
  std::snprintf(text, sizeof text,
                "%s%s: the position stepped %+.9g %s%s in %.6g ms, over the limit of %.6g %s (max_velocity "
                "%.6g %s/s x %.6g ms%s)",
                std::string(to_string(FaultReason::encoder_jump)).c_str(), axis, jump.step, unit, counts,
                jump.interval_s * 1e3, jump.limit, unit, rule.max_velocity, unit, jump.interval_s * 1e3,
                count);
  return text;
}

}  // namespace hapticd::daemon::engine
