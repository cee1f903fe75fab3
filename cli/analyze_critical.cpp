// hapticctl analyze critical-stiffness: the gain margin of the sampled spring
// loop on a rigid or two-mass device (Diaz & Gil eq. 21-28, 30).

#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "analysis/critical_stiffness.hpp"
#include "analysis/two_mass.hpp"
#include "cli/analyze_common.hpp"
#include "cli/arguments.hpp"
#include "cli/usage_error.hpp"

namespace hapticd::cli {

namespace {

struct CriticalArgs {
  std::string plant = "rigid", period, delay = "0", sensor = "motor";
  std::string mass, damping;
  std::string motor_mass, body_mass, motor_damping, body_damping, cable_stiffness, cable_damping;
  std::vector<CLI::Option*> given;  ///< the plant flags, to tell "not given" from an empty value
  bool json = false;
};

double value_or(const CriticalArgs& a, const std::string& flag, const std::string& text, double fallback,
                std::string_view unit, bool positive) {
  bool given = false;
  for (const CLI::Option* o : a.given) given = given || (o->get_name() == flag && o->count() > 0);
  if (!given) return fallback;
  return positive ? positive_number(flag, text, unit) : non_negative_number(flag, text, unit);
}

/// 0 to max_delay_periods periods (the phase scan resolves them), and at most 1 s.
double delay_flag(const std::string& text, double period) {
  const double max_delay = analysis::max_delay_periods * period;
  return duration_within("--delay", text, 0.0, max_delay,
                         "a duration from 0 to " + std::to_string(analysis::max_delay_periods) +
                             " periods (" + fmt_duration(max_delay) + " at T = " + fmt_duration(period) +
                             ") such as 0, 2ms or 250us");
}

/// The plant the flags describe, Table I's values where a flag is not given.
struct CriticalPlant {
  world::LinearPlant model;
  std::optional<world::TwoMassPlant> two_mass;  ///< --plant two-mass
};

/// --plant and its parameters; each parameter also goes into the JSON output.
CriticalPlant critical_plant(const CriticalArgs& a, nlohmann::json& out) {
  CriticalPlant plant;
  if (a.plant == "rigid") {
    world::TwoMassPlant table1;  // its totals are Diaz & Gil's rigid model: m = 5.4 kg, b = 3.5 N s/m
    const double m = value_or(a, "--mass", a.mass, table1.total_mass(), "kg", true);
    const double b = value_or(a, "--damping", a.damping, table1.total_damping(), "N s/m", false);
    plant.model = world::RigidPlant{m, b}.model();
    out["mass"] = m;
    out["damping"] = b;
  } else if (a.plant == "two-mass") {
    world::TwoMassPlant p;
    p.motor_mass = value_or(a, "--motor-mass", a.motor_mass, p.motor_mass, "kg", true);
    p.body_mass = value_or(a, "--body-mass", a.body_mass, p.body_mass, "kg", true);
    p.motor_damping = value_or(a, "--motor-damping", a.motor_damping, p.motor_damping, "N s/m", false);
    p.body_damping = value_or(a, "--body-damping", a.body_damping, p.body_damping, "N s/m", false);
    p.cable_stiffness = value_or(a, "--cable-stiffness", a.cable_stiffness, p.cable_stiffness, "N/m", true);
    p.cable_damping = value_or(a, "--cable-damping", a.cable_damping, p.cable_damping, "N s/m", false);
    plant.model = p.model();
    plant.two_mass = p;
    out["motor_mass"] = p.motor_mass;
    out["body_mass"] = p.body_mass;
    out["motor_damping"] = p.motor_damping;
    out["body_damping"] = p.body_damping;
    out["cable_stiffness"] = p.cable_stiffness;
    out["cable_damping"] = p.cable_damping;
  } else {
    throw UsageError("--plant: '" + a.plant + "' is not accepted; expected rigid or two-mass");
  }
  return plant;
}

/// K_CR and, on a two-mass plant, the cable mode into the JSON output.
void add_critical_results(nlohmann::json& out, const analysis::CriticalStiffness& k,
                          const std::optional<analysis::ResonanceParameters>& modes,
                          const std::optional<world::TwoMassPlant>& two_mass) {
  if (k.assessed()) {
    out["k_cr"] = k.k_cr;
    out["crossover_hz"] = k.crossover_hz;
    out["crossover_rad_per_s"] = k.crossover_rad_per_s;
    out["gain_margin_db"] = k.gain_margin_db;
  }
  if (modes && modes->assessed()) {
    out["q"] = modes->q;
    out["q_db"] = modes->q_db;
    out["omega_n"] = modes->omega_n;
    out["z_n"] = modes->z_n;
    if (const auto peak = analysis::resonant_peak(*two_mass))
      out["resonant_peak_distance_db"] = peak->distance_db;
  }
}

/// The table without --json: the loop, K_CR, the cable mode and the verdict.
void print_critical_table(const CriticalArgs& a, world::Sensor sensor, double period, double delay,
                          const analysis::CriticalStiffness& k,
                          const std::optional<analysis::ResonanceParameters>& modes) {
  Table t;
  t.row("plant", a.plant + ", " + std::string(world::to_string(sensor)) + " sensing, T = " +
                     fmt_duration(period) + ", delay " + fmt_duration(delay == 0.0 ? 0.0 : delay));
  if (k.assessed()) {
    t.row("critical stiffness", fmt(k.k_cr) + " N/m (gain margin " + fmt(k.gain_margin_db) + " dB)");
    t.row("phase crossover", fmt(k.crossover_hz) + " Hz (" + fmt(k.crossover_rad_per_s) + " rad/s)");
  }
  if (modes && modes->assessed()) {
    t.row("cable mode",
          "w_n = " + fmt(modes->omega_n) + " rad/s, z_n = " + fmt(modes->z_n) + " 1/s (eq. 13, 16)");
    t.row("Q ~ m_m z_n w_n", fmt(modes->q) + " N/m = " + fmt(modes->q_db) + " dB (eq. 24)");
  }
  if (modes) {
    const auto rigid_suffices = analysis::rigid_model_suffices(*modes, k);
    t.row("verdict", !rigid_suffices   ? std::string("cannot assess (see below)")
                     : *rigid_suffices ? std::string("Q >= K_CR: the rigid model suffices at this delay")
                                       : std::string("Q < K_CR: the cable mode limits the stiffness"));
  } else if (!k.assessed()) {
    t.row("verdict", "cannot assess (see below)");
  }
  t.print(std::cout);
}

void run_critical(const CriticalArgs& a) {
  const double period = period_flag(a.period);
  const double delay = delay_flag(a.delay, period);
  const auto sensor = world::parse_sensor(a.sensor);
  if (!sensor) throw UsageError("--sensor: '" + a.sensor + "' is not accepted; expected motor or body");
  nlohmann::json out;
  const CriticalPlant plant = critical_plant(a, out);
  const auto k = analysis::critical_stiffness(plant.model, *sensor, period, delay);
  std::optional<analysis::ResonanceParameters> modes;
  if (plant.two_mass) modes = analysis::resonance_parameters(*plant.two_mass);
  // Not assessed: the first reason, the cable mode's (closer to the inputs) before K_CR's.
  std::string cannot_assess = modes ? modes->numerics.reason() : std::string();
  if (cannot_assess.empty()) cannot_assess = k.numerics.reason();
  out["plant"] = a.plant;
  out["sensor"] = world::to_string(*sensor);
  out["period"] = period;
  out["delay"] = delay;
  out["verdict"] = cannot_assess.empty() ? "assessed" : "cannot_assess";
  out["reason"] = cannot_assess.empty() ? nlohmann::json(nullptr) : nlohmann::json(cannot_assess);
  add_critical_results(out, k, modes, plant.two_mass);
  if (a.json) {
    std::cout << out.dump(2) << "\n";
  } else {
    print_critical_table(a, *sensor, period, delay, k, modes);
  }
  if (!cannot_assess.empty()) throw CannotAssess(cannot_assess);
}

}  // namespace

void add_analyze_critical_stiffness(CLI::App& analyze) {
  auto a = std::make_shared<CriticalArgs>();
  auto* cmd = analyze.add_subcommand("critical-stiffness",
                                     "K_CR = gain margin of Z[H(s) G(s) e^(-td s)] (Diaz & Gil eq. 21-30)");
  cmd->add_option("--plant", a->plant, "rigid or two-mass (default rigid)");
  cmd->add_option("--period", a->period, "sampling period, 1 us to 1 s (s, ms, us)")->required();
  cmd->add_option("--delay", a->delay,
                  "loop delay t_d, 0 to 100 periods (s, ms, us; fractions of T allowed; default 0)");
  cmd->add_option("--sensor", a->sensor, "motor (G_m, eq. 23) or body (G_c, eq. 30); default motor");
  a->given.push_back(cmd->add_option("--mass", a->mass, "rigid: mass m, kg (default 5.4, Table I)"));
  a->given.push_back(
      cmd->add_option("--damping", a->damping, "rigid: damping b, N s/m (default 3.5, Table I)"));
  a->given.push_back(cmd->add_option("--motor-mass", a->motor_mass, "two-mass: m_m, kg (default 0.3)"));
  a->given.push_back(cmd->add_option("--body-mass", a->body_mass, "two-mass: m_d, kg (default 5.1)"));
  a->given.push_back(
      cmd->add_option("--motor-damping", a->motor_damping, "two-mass: b_m, N s/m (default 0.1)"));
  a->given.push_back(
      cmd->add_option("--body-damping", a->body_damping, "two-mass: b_d, N s/m (default 3.4)"));
  a->given.push_back(
      cmd->add_option("--cable-stiffness", a->cable_stiffness, "two-mass: k_c, N/m (default 79500)"));
  a->given.push_back(
      cmd->add_option("--cable-damping", a->cable_damping, "two-mass: b_c, N s/m (default 15)"));
  cmd->add_flag("--json", a->json, "print one JSON object");
  cmd->callback([a] { run_critical(*a); });
}

}  // namespace hapticd::cli
