// hapticctl analyze passivity: the device damping a scene needs to be passive
// (Colgate & Schenkel 1997; analysis/passivity.hpp), for the wall and the
// spring scenes, and with --device-damping whether this device has it and the
// stiffest passive setting.

#include <cmath>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "analysis/passivity.hpp"
#include "cli/analyze_common.hpp"
#include "cli/arguments.hpp"
#include "cli/usage_error.hpp"

namespace hapticd::cli {

namespace {

struct PassivityArgs {
  std::string scene = "wall", stiffness, damping, period, delay, device_damping;
  std::string inertia, mass, damping_reference, integrator;
  CLI::Option* device_flag = nullptr;  ///< given at all (an empty value is an error, not "absent")
  CLI::Option* inertia_flag = nullptr;
  CLI::Option* mass_flag = nullptr;
  CLI::Option* reference_flag = nullptr;
  CLI::Option* integrator_flag = nullptr;
  bool json = false;
};

struct PassivityUnits {
  std::string stiffness, damping;
};

/// What was asked, in SI, and its verdict.
struct Query {
  std::string scene;
  PassivityUnits units;
  double stiffness = 0.0, period = 0.0;
  int delay = 0;
  std::string damping_text;  ///< the damping as given ("auto" resolved in `damping`)
  double damping = 0.0;
  std::optional<analysis::SpringPassivityInput> spring;
  analysis::PassivityVerdict verdict;
};

void refuse_spring_flags(const PassivityArgs& a) {
  for (const CLI::Option* o : {a.inertia_flag, a.mass_flag, a.reference_flag, a.integrator_flag}) {
    if (o->count() > 0) throw UsageError(o->get_name() + ": not a parameter of wall");
  }
}

analysis::SpringPassivityInput spring_input(const PassivityArgs& a, Query& q) {
  const bool wheel = q.scene == "spring-wheel";
  const CLI::Option* wanted = wheel ? a.inertia_flag : a.mass_flag;
  const CLI::Option* other = wheel ? a.mass_flag : a.inertia_flag;
  if (other->count() > 0) throw UsageError(other->get_name() + ": not a parameter of " + q.scene);
  if (wanted->count() == 0)
    throw UsageError(wanted->get_name() + ": " + q.scene + " needs its virtual " +
                     (wheel ? "inertia (kg m^2)" : "mass (kg)"));
  analysis::SpringPassivityInput in;
  in.parameters.stiffness = q.stiffness;
  in.parameters.inertia =
      wheel ? positive_number("--inertia", a.inertia, "kg m^2") : positive_number("--mass", a.mass, "kg");
  in.damping_auto = a.damping == "auto";
  in.parameters.damping =
      in.damping_auto ? q.period * q.stiffness
                      : non_negative_number("--damping", a.damping, q.units.damping + ", or auto (b = T k)");
  if (a.reference_flag->count() > 0 && a.damping_reference != "relative") {
    if (a.damping_reference != "absolute")
      throw UsageError("--damping-reference: '" + a.damping_reference +
                       "' is not accepted; expected relative or absolute");
    in.reference = world::SpringDamping::absolute;
  }
  if (a.integrator_flag->count() > 0) {
    const auto integrator = world::parse_integrator(a.integrator);
    if (!integrator)
      throw UsageError("--integrator: '" + a.integrator + "' is not accepted; expected one of " +
                       std::string(world::integrator_names()));
    in.parameters.integrator = *integrator;
  }
  in.period_s = q.period;
  in.delay_samples = q.delay;
  q.damping = in.parameters.damping;
  return in;
}

Query evaluate(const PassivityArgs& a) {
  Query q;
  q.scene = a.scene;
  if (q.scene != "wall" && q.scene != "spring-wheel" && q.scene != "spring-mass")
    throw UsageError("--scene: '" + a.scene +
                     "' is not accepted; expected wall, spring-wheel or spring-mass");
  const bool rotary = q.scene == "spring-wheel";
  q.units = rotary ? PassivityUnits{"N m/rad", "N m s/rad"} : PassivityUnits{"N/m", "N s/m"};
  q.stiffness = non_negative_number("--stiffness", a.stiffness, q.units.stiffness);
  q.period = period_flag(a.period);
  q.delay = whole_number("--delay", a.delay, 0, 64);
  q.damping_text = a.damping;
  std::optional<double> device;
  if (a.device_flag->count() > 0)
    device = non_negative_number("--device-damping", a.device_damping, q.units.damping);
  if (q.scene == "wall") {
    refuse_spring_flags(a);
    q.damping = non_negative_number("--damping", a.damping, q.units.damping);
    q.verdict = analysis::analyze_wall_passivity(q.stiffness, q.damping, q.period, q.delay, device);
  } else {
    q.spring = spring_input(a, q);
    q.verdict = analysis::analyze_spring_passivity(*q.spring, device);
  }
  return q;
}

nlohmann::json to_json(const Query& q) {
  const analysis::PassivityBound& b = q.verdict.bound;
  const nlohmann::json null = nullptr;
  nlohmann::json out{{"scene", q.scene},
                     {"stiffness", q.stiffness},
                     {"damping", q.damping},
                     {"period", q.period},
                     {"delay", q.delay},
                     {"damping_unit", q.units.damping},
                     {"state", analysis::to_string(b.state)},
                     {"reason", b.reason.empty() ? null : nlohmann::json(b.reason)},
                     {"required_damping", b.bounded() ? nlohmann::json(b.required_damping) : null},
                     {"passive_at_any_damping", b.state != analysis::PassivityState::unbounded},
                     {"frequency_hz", b.assessed() ? nlohmann::json(b.frequency_hz) : null},
                     {"at_zero_frequency_limit", b.at_zero_frequency_limit}};
  if (q.spring) {
    out[q.scene == "spring-wheel" ? "inertia" : "mass"] = q.spring->parameters.inertia;
    out["damping_auto"] = q.spring->damping_auto;
    out["damping_reference"] =
        q.spring->reference == world::SpringDamping::absolute ? "absolute" : "relative";
    out["integrator"] = world::to_string(q.spring->parameters.integrator);
  }
  if (q.verdict.device_damping) {
    out["device_damping"] = *q.verdict.device_damping;
    out["passive"] = q.verdict.passive;
    out["max_stiffness"] = b.assessed() ? nlohmann::json(q.verdict.max_stiffness) : null;
    out["max_stiffness_at_range_top"] = q.verdict.max_stiffness_at_range_top;
  }
  return out;
}

void print_human(const Query& q) {
  const analysis::PassivityBound& b = q.verdict.bound;
  Table t;
  std::string scene = q.scene + ": k = " + fmt(q.stiffness) + " " + q.units.stiffness +
                      ", b = " + fmt(q.damping) + " " + q.units.damping +
                      (q.spring && q.spring->damping_auto ? " (auto)" : "");
  if (q.scene == "wall") scene = "wall: K = " + fmt(q.stiffness) + " N/m, B = " + fmt(q.damping) + " N s/m";
  if (q.spring) {
    scene +=
        ", " + std::string(q.scene == "spring-wheel" ? "J = " + fmt(q.spring->parameters.inertia) + " kg m^2"
                                                     : "m = " + fmt(q.spring->parameters.inertia) + " kg");
    scene += ", " + std::string(world::to_string(q.spring->parameters.integrator));
  }
  t.row("scene", scene);
  t.row("sampling", "T = " + fmt_duration(q.period) + ", d = " + std::to_string(q.delay));
  if (b.bounded()) {
    const std::string where = b.at_zero_frequency_limit ? "as f -> 0" : "at " + fmt(b.frequency_hz) + " Hz";
    t.row("required damping", fmt(b.required_damping) + " " + q.units.damping + " (" + where +
                                  "; Colgate & Schenkel: passive iff the device's b >= this)");
  } else if (b.state == analysis::PassivityState::unbounded) {
    t.row("required damping", "none suffices: " + b.reason);
  } else {
    t.row("required damping", "cannot assess (see below)");
  }
  if (q.verdict.device_damping && b.assessed()) {
    t.row("device damping", fmt(*q.verdict.device_damping) + " " + q.units.damping + ": " +
                                (q.verdict.passive ? "passive" : "NOT PASSIVE"));
    const std::string k = fmt(q.verdict.max_stiffness) + " " + q.units.stiffness;
    std::string note = q.verdict.max_stiffness > 0.0 ? " at this damping" : " (none at this damping)";
    if (q.verdict.max_stiffness_at_range_top) note = " (passive up to the accepted range's top)";
    t.row("largest passive stiffness", k + note);
  }
  t.print(std::cout);
}

void run_passivity(const PassivityArgs& a) {
  const Query q = evaluate(a);
  if (a.json) {
    std::cout << to_json(q).dump(2) << "\n";
  } else {
    print_human(q);
  }
  if (!q.verdict.bound.assessed()) throw CannotAssess(q.verdict.bound.reason);
}

}  // namespace

void add_analyze_passivity(CLI::App& analyze) {
  auto args = std::make_shared<PassivityArgs>();
  auto* cmd = analyze.add_subcommand(
      "passivity", "Device damping a wall or spring needs to be passive (Colgate & Schenkel 1997)");
  cmd->add_option("--scene", args->scene, "wall (default), spring-wheel or spring-mass");
  cmd->add_option("--stiffness", args->stiffness, "stiffness K or k, N/m (N m/rad for spring-wheel)")
      ->required();
  cmd->add_option("--damping", args->damping, "damping B or b, N s/m (N m s/rad); springs: or auto (b = T k)")
      ->required();
  cmd->add_option("--period", args->period, "sampling period, 1 us to 1 s (s, ms, us)")->required();
  cmd->add_option("--delay", args->delay, "delay d, whole samples 0 to 64 (wall: Hulin's d; springs: device)")
      ->required();
  args->device_flag = cmd->add_option("--device-damping", args->device_damping,
                                      "the device's physical damping b, N s/m (N m s/rad)");
  args->inertia_flag =
      cmd->add_option("--inertia", args->inertia, "spring-wheel: virtual inertia J_w, kg m^2");
  args->mass_flag = cmd->add_option("--mass", args->mass, "spring-mass: virtual mass m, kg");
  args->reference_flag = cmd->add_option("--damping-reference", args->damping_reference,
                                         "springs: relative (default) or absolute");
  args->integrator_flag =
      cmd->add_option("--integrator", args->integrator,
                      "springs: forward-euler, semi-implicit-euler, trapezoid, rk4, exact "
                      "(default)");
  cmd->add_flag("--json", args->json, "print one JSON object");
  cmd->callback([args] { run_passivity(*args); });
}

}  // namespace hapticd::cli
