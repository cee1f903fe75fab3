// The loopback driver's description (drivers/driver_description.hpp): its
// typed parameters and the factory of its hooks.
#include "drivers/loopback/loopback_config.hpp"
#include "drivers/loopback/loopback_device.hpp"
#include "world/parameter.hpp"

namespace hapticd::drivers::loopback {

namespace {

using P = ParameterSpec;

/// A Cartesian stage's keys (LoopbackStage): how many axes, and what differs per axis.
std::vector<ParameterSpec> stage_parameters() {
  return {
      P::integer("axes", "",
                 "axes simulated together: 1 (today's loopback) or a Cartesian stage of 2 to 6 rigid, "
                 "linear axes, one plant each, read and written at one sample instant")
          .defaults_to(1.0)
          .at_least(1.0)
          .at_most(static_cast<double>(max_axes)),
      P::text(
          "axis_mass",
          "axes > 1: each axis' moving mass in kg, comma-separated (\"0.1,0.3\"); unset: mass on every axis")
          .defaults_to(""),
      P::text("axis_damping",
              "axes > 1: each axis' viscous damping in N s/m, comma-separated; unset: damping on every axis")
          .defaults_to(""),
      P::text("axis_weight",
              "a constant force on each axis in N, comma-separated (\"0,-0.98\": -m g on a vertical y "
              "whose positive direction is up, for [gravity]; one axis: one number); unset: 0 on every axis")
          .defaults_to(""),
      P::text("hands",
              "axes > 1: one hand script per axis, separated by ';' (\"mode=hold trajectory=ramp to=0.01 "
              "rate=0.01; mode=free\"); unset: the hand table on every axis (a pantograph: free joints)")
          .defaults_to(""),
      P::choice("linkage", {"cartesian", "pantograph"},
                "cartesian (axes independent: a stage) or pantograph (the planar five-bar linkage of "
                "Hapkit/Haply 2-DOF devices: two rotary motor joints, the hand on the handle; set "
                "[device] kinematics = \"pantograph\")")
          .defaults_to("cartesian"),
      P::text("links",
              "pantograph: a1,a2,a3,a4,a5 in m (Campion et al. 2005: proximal left, distal left, distal "
              "right, proximal right, the motors' distance)")
          .defaults_to("0.07,0.09,0.09,0.07,0.0381"),
      P::text("joint_inertia", "pantograph: each motor joint's inertia in kg m^2, comma-separated")
          .defaults_to("0.0005,0.0005"),
      P::text("joint_damping", "pantograph: each motor joint's viscous damping in N m s/rad, comma-separated")
          .defaults_to("0,0"),
      P::text("workspace",
              "pantograph: the task-space box x_min,x_max,y_min,y_max in m it is used in (the gate's worst "
              "case is over it; it must be reachable and away from singularities everywhere)")
          .defaults_to("-0.02,0.06,0.07,0.12"),
      P::text("start", "pantograph: the handle's position x,y at start-up, m; unset: the workspace's centre")
          .defaults_to(""),
      P::text("link_masses",
              "pantograph in a vertical plane (y up): the weights of the proximal left, distal left, "
              "distal right and proximal right links (each at its middle) and of the handle, kg, "
              "comma-separated, for [gravity]; their inertia is in joint_inertia; unset: weightless")
          .defaults_to(""),
  };
}

std::vector<ParameterSpec> make_parameters() {
  // Ranges: world::parameter_range, as for the scenes (a value outside is a
  // typo, not a device); PlantConfig::validate() checks the same.
  namespace r = world::parameter_range;
  const LoopbackConfig rotary = LoopbackConfig::defaults(Motion::rotary);
  const LoopbackConfig linear = LoopbackConfig::defaults(Motion::linear);
  const world::TwoMassPlant tm{};
  auto note = [](double v, const char* unit) {
    return "rotary; " + to_text(ParameterValue(v)) + " " + unit + " when motion = linear";
  };
  return {
      motion_parameter("rotary (wheel: rad, N m, kg m^2) or linear (m, N, kg); selects the defaults below"),
      P::choice("plant", {"rigid", "two-mass", "two_mass"},
                "rigid (one mass) or two-mass (motor and body joined by a cable, Diaz & Gil eq. 3-9)")
          .defaults_to("rigid"),
      mass_parameter("rigid plant: moving inertia (rotary) or mass (linear)")
          .defaults_to(rotary.mass, note(linear.mass, "kg")),
      damping_parameter("rigid plant: viscous damping to ground")
          .defaults_to(rotary.damping, note(linear.damping, "N s/m")),
      P::number(
          "coulomb", "N m | N",
          "Coulomb friction level with stiction (rigid: on the mass; two-mass: on the body); 0 disables")
          .defaults_to(0.0)
          .at_least(0.0)
          .at_most(r::max_force),
      P::number("motor_mass", "kg", "two-mass: motor-side mass m_m (Table I)")
          .defaults_to(tm.motor_mass)
          .at_least(r::min_mass)
          .at_most(r::max_mass),
      P::number("body_mass", "kg", "two-mass: body (handle) mass m_d (Table I)")
          .defaults_to(tm.body_mass)
          .at_least(r::min_mass)
          .at_most(r::max_mass),
      P::number("motor_damping", "N s/m", "two-mass: motor damping b_m (Table I)")
          .defaults_to(tm.motor_damping)
          .at_least(0.0)
          .at_most(r::max_damping),
      P::number("body_damping", "N s/m", "two-mass: body damping b_d (Table I)")
          .defaults_to(tm.body_damping)
          .at_least(0.0)
          .at_most(r::max_damping),
      P::number("cable_stiffness", "N/m", "two-mass: cable stiffness k_c (Table I)")
          .defaults_to(tm.cable_stiffness)
          .above(0.0)
          .at_most(r::max_stiffness),
      P::number("cable_damping", "N s/m", "two-mass: cable damping b_c (Table I)")
          .defaults_to(tm.cable_damping)
          .at_least(0.0)
          .at_most(r::max_damping),
      P::choice(
          "sensor", {"motor", "body", "hand", "user"},
          "two-mass: position read() returns: motor (collocated) or body (non-collocated; also hand, user)")
          .defaults_to("motor"),
      P::number("counts", "1/rev | 1/m", "encoder counts per revolution (rotary) or per metre (linear)")
          .defaults_to(rotary.counts, note(linear.counts, "1/m"))
          .at_least(1.0)
          .at_most(simulation::max_counts),
      P::number("max_force", "N m | N", "actuator saturation |force|")
          .defaults_to(rotary.max_force, note(linear.max_force, "N"))
          .above(0.0)
          .at_most(r::max_force),
      P::integer("delay", "periods",
                 "extra output delay: a force written in period n is applied in period n+delay")
          .defaults_to(0.0)
          .at_least(0.0)
          .at_most(static_cast<double>(max_delay_periods)),
      P::table(
          "hand",
          "the scripted hand, e.g. [device.loopback.hand] mode = \"hold\", trajectory = \"step\", "
          "amplitude = 0.785, at = 0.5 (or hand = \"mode=hold ...\"); hapticctl hand changes it at run time"),
  };
}

}  // namespace

const std::vector<ParameterSpec>& loopback_parameters() {
  static const std::vector<ParameterSpec> parameters = [] {
    std::vector<ParameterSpec> all = make_parameters();
    for (auto& key : stage_parameters()) all.push_back(std::move(key));
    return all;
  }();
  return parameters;
}

DriverDescription loopback_driver() {
  return {"loopback", "simulated plant (rigid or two-mass), scripted hand, fault injection: tests and demos",
          true, loopback_parameters(), [](const DriverParameters& p) -> std::unique_ptr<DeviceHooks> {
            return std::make_unique<LoopbackDevice>(loopback_stage_from(p));
          }};
}

}  // namespace hapticd::drivers::loopback
