// hapticctl report stability: the stability maps (analysis/stability_maps.hpp)
// and the sweep of stiff and extreme cases (analysis/stability_sweep.hpp):
// prediction, time-domain run and the daemon's gate for each; exit 1 when
// any case disagrees.

#include <chrono>
#include <cmath>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>

#include "analysis/accuracy_study.hpp"
#include "analysis/passivity.hpp"
#include "analysis/stability_maps.hpp"
#include "analysis/stability_sweep.hpp"
#include "analysis/wall_stability.hpp"
#include "cli/analyze_common.hpp"
#include "cli/arguments.hpp"
#include "cli/report.hpp"
#include "cli/report_figure.hpp"
#include "cli/usage_error.hpp"
#include "cli/verbs.hpp"

namespace hapticd::cli {

namespace {

using analysis::SweepAgreement;
using analysis::SweepResult;

struct StabilityArgs {
  std::string out = "hapticd-report";
  bool json = false;
  bool quick = false;
  std::string mass = "0.1", period = "1ms", delay = "1", stiffness = "9000", damping = "46";
  std::string device_damping = "2";  ///< N s/m: the passivity boundary's device
};

/// The wall the operating point of the region map stands for.
struct OperatingPoint {
  double mass = 0.0, period_s = 0.0, stiffness = 0.0, damping = 0.0;
  int delay = 0;
  double device_damping = 0.0;  ///< b, N s/m, for the passivity boundary
  double alpha() const { return analysis::normalized_stiffness(stiffness, mass, period_s); }
  double beta() const { return analysis::normalized_damping(damping, mass, period_s); }
  double device_beta() const { return analysis::normalized_damping(device_damping, mass, period_s); }
  analysis::PassivityVerdict passivity() const {
    return analysis::analyze_wall_passivity(stiffness, damping, period_s, delay, device_damping);
  }
};

struct Maps {
  analysis::WallRegionMap wall;
  std::vector<analysis::WallMapPoint> passivity;  ///< Colgate & Schenkel at the operating point's b T / m
  std::vector<analysis::IntegratorRegionRow> integrators;
  std::vector<analysis::CriticalStiffnessRow> critical;
  double critical_period_s = 1e-3;
};

constexpr int map_delays = 8;

std::string delay_colour(int d) {
  static constexpr const char* palette[] = {"#1b9e77", "#d95f02", "#7570b3", "#e7298a", "#66a61e",
                                            "#e6ab02", "#a6761d", "#666666", "#1f78b4"};
  return palette[d % 9];
}

Figure wall_figure(const Maps& m, const OperatingPoint& op) {
  Figure f;
  f.name = "stability_wall_region";
  f.title =
      "Hulin's virtual wall: stable below each boundary alpha_max(beta), d = 0 .. 8 samples of delay\n"
      "dashed: minimum pole radius (6.2), dotted: maximum damping (6.1); star: K = " +
      fmt(op.stiffness) + " N/m, B = " + fmt(op.damping) + " N s/m on " + fmt(op.mass) +
      " kg, T = " + fmt_duration(op.period_s) + ", d = " + std::to_string(op.delay) +
      "\ndash-dot: passive below (Colgate & Schenkel) on a device damping b = " + fmt(op.device_damping) +
      " N s/m (b T / m = " + fmt(op.device_beta()) + "); Hulin's region is for b = 0";
  f.x = {"normalized damping {/Symbol b} = B T / m", true, "[1e-4:3]"};
  f.y = {"normalized stiffness {/Symbol a} = K T^2 / m", true, "[1e-7:1.5]"};
  f.data.columns = {"curve", "delay", "beta", "alpha"};
  const auto add = [&](const std::string& curve, const std::vector<analysis::WallMapPoint>& points) {
    for (const auto& p : points)
      f.data.rows.push_back({curve, static_cast<double>(p.delay), p.beta, p.alpha});
  };
  add("boundary", m.wall.boundary);
  add("minimum-radius", m.wall.minimum_radius_path);
  add("maximum-damping", m.wall.maximum_damping_path);
  add("maximum-stiffness", m.wall.maximum_stiffness);
  add("passivity-boundary", m.passivity);
  f.data.rows.push_back(
      {std::string("operating-point"), static_cast<double>(op.delay), op.beta(), op.alpha()});
  for (int d = 0; d <= map_delays; ++d) {
    const std::string c = "lc rgb '" + delay_colour(d) + "'";
    const double delay = d;
    f.curves.push_back({"d = " + std::to_string(d),
                        {{"curve", std::string("boundary")}, {"delay", delay}},
                        "beta",
                        "alpha",
                        "lines lw 2 " + c});
    f.curves.push_back({"",
                        {{"curve", std::string("minimum-radius")}, {"delay", delay}},
                        "beta",
                        "alpha",
                        "lines dt 2 lw 1.2 " + c});
    f.curves.push_back({"",
                        {{"curve", std::string("maximum-damping")}, {"delay", delay}},
                        "beta",
                        "alpha",
                        "lines dt 3 lw 1.2 " + c});
    f.curves.push_back({d == 0 ? "passive below (dash-dot)" : "",
                        {{"curve", std::string("passivity-boundary")}, {"delay", delay}},
                        "beta",
                        "alpha",
                        "lines dt 4 lw 1.5 " + c});
  }
  f.curves.push_back({"Remark 2 maxima",
                      {{"curve", std::string("maximum-stiffness")}},
                      "beta",
                      "alpha",
                      "points pt 5 ps 1.2 lc rgb 'black'"});
  f.curves.push_back({"operating point",
                      {{"curve", std::string("operating-point")}},
                      "beta",
                      "alpha",
                      "points pt 3 ps 3 lw 3 lc rgb 'red'"});
  f.key = "inside left top font ',10'";
  f.meta = {{"operating_point",
             {{"mass_kg", op.mass},
              {"period_s", op.period_s},
              {"delay", op.delay},
              {"stiffness", op.stiffness},
              {"damping", op.damping},
              {"alpha", op.alpha()},
              {"beta", op.beta()},
              {"stable", analysis::wall_stable(op.alpha(), op.beta(), op.delay)}}}};
  const analysis::PassivityVerdict passivity = op.passivity();
  f.meta["passivity"] = {{"device_damping", op.device_damping},
                         {"device_beta", op.device_beta()},
                         {"required_damping", passivity.bound.required_damping},
                         {"passive", passivity.passive},
                         {"max_stiffness", passivity.max_stiffness}};
  return f;
}

Figure integrator_figure(const Maps& m) {
  Figure f;
  f.name = "stability_integrator_regions";
  f.title =
      "Spring scene, device held: where each explicit integrator is stable (shaded; trapezoid and exact: "
      "everywhere)\nblack dashed: Freudenberg 2.14, zeta = w_n T / 2; star: the 1 Hz wheel with b = T k at T "
      "= 1 ms";
  f.x = {"w_n T (rad per period)", true, "[1e-3:1e2]"};
  f.y = {"damping ratio {/Symbol z} = b / (2 sqrt(k J))", true, "[1e-5:1e3]"};
  f.data.columns = {"integrator", "wn_t",       "zeta_lower", "zeta_upper",
                    "band_lower", "band_upper", "freudenberg"};
  constexpr double bottom = 1e-5, top = 1e3;  // the plot's range: stable down to 0, up to the scan's end
  for (const auto& r : m.integrators) {
    f.data.rows.push_back({std::string(world::to_string(r.integrator)), r.wn_t, r.zeta_lower, r.zeta_upper,
                           std::max(r.zeta_lower, bottom), std::min(r.zeta_upper, top), r.wn_t / 2.0});
  }
  const double h = 2 * std::numbers::pi * 1e-3;
  f.data.rows.push_back({std::string("operating-point"), h, h / 2.0, NAN, NAN, NAN, NAN});
  for (const world::Integrator i :
       {world::Integrator::semi_implicit_euler, world::Integrator::rk4, world::Integrator::forward_euler}) {
    const std::string name(world::to_string(i));
    const std::string colour = colour_for(name);
    f.curves.push_back({name,
                        {{"integrator", name}},
                        "wn_t",
                        "band_lower",
                        "filledcurves fs transparent solid 0.25 noborder lc rgb '" + colour + "'",
                        "band_upper"});
    // The boundaries themselves (0 and inf do not show on log axes).
    f.curves.push_back(
        {"", {{"integrator", name}}, "wn_t", "zeta_lower", "lines lw 2 lc rgb '" + colour + "'"});
    f.curves.push_back(
        {"", {{"integrator", name}}, "wn_t", "zeta_upper", "lines lw 2 lc rgb '" + colour + "'"});
  }
  f.curves.push_back({"zeta = w_n T / 2",
                      {{"integrator", std::string("forward-euler")}},
                      "wn_t",
                      "freudenberg",
                      "lines dt 2 lw 1.5 lc rgb 'black'"});
  f.curves.push_back({"1 Hz wheel, b = T k, T = 1 ms",
                      {{"integrator", std::string("operating-point")}},
                      "wn_t",
                      "zeta_lower",
                      "points pt 3 ps 3 lw 3 lc rgb 'red'"});
  f.key = "inside right top";
  return f;
}

Figure critical_figure(const Maps& m) {
  Figure f;
  f.name = "stability_critical_stiffness";
  f.title = "Diaz & Gil: critical stiffness of a sampled spring on the LHifAM (Table I), T = " +
            fmt_duration(m.critical_period_s) + "\nsquare: the Jury closed form at td = 0 (rigid)";
  f.x = {"loop delay td (ms)", false, ""};
  f.y = {"K_{CR} (N/m)", true, ""};
  f.data.columns = {"plant", "sensor", "delay_ms", "k_cr", "crossover_hz"};
  for (const auto& r : m.critical) {
    f.data.rows.push_back(
        {r.plant, std::string(world::to_string(r.sensor)), r.delay_s * 1e3, r.k_cr, r.crossover_hz});
  }
  const world::TwoMassPlant plant;
  const double jury =
      analysis::rigid_critical_stiffness_jury(plant.total_mass(), plant.total_damping(), m.critical_period_s);
  f.data.rows.push_back({std::string("jury"), std::string("motor"), 0.0, jury, NAN});
  f.curves.push_back({"rigid (m = 5.4 kg, b = 3.5 N s/m)",
                      {{"plant", std::string("rigid")}},
                      "delay_ms",
                      "k_cr",
                      "lines lw 2 lc rgb '#1b9e77'"});
  f.curves.push_back({"two-mass, motor sensing",
                      {{"plant", std::string("two-mass")}, {"sensor", std::string("motor")}},
                      "delay_ms",
                      "k_cr",
                      "lines lw 2 lc rgb '#d95f02'"});
  f.curves.push_back({"two-mass, body sensing",
                      {{"plant", std::string("two-mass")}, {"sensor", std::string("body")}},
                      "delay_ms",
                      "k_cr",
                      "lines lw 2 dt 2 lc rgb '#7570b3'"});
  f.curves.push_back({"Jury closed form (rigid, td = 0)",
                      {{"plant", std::string("jury")}},
                      "delay_ms",
                      "k_cr",
                      "points pt 5 ps 1.5 lc rgb 'black'"});
  f.meta = {{"jury_k_cr_td0", jury}};
  f.key = "inside right top";
  return f;
}

/// sign(g) log10(1 + |g|): keeps sign, compresses decades.
double signed_log(double g) {
  return std::isfinite(g) ? std::copysign(std::log10(1.0 + std::abs(g)), g) : NAN;
}

double predicted_per_second(const SweepResult& r) {
  return analysis::log10_growth_per_second(r.predicted_log_growth, r.input.device.period_s);
}
double measured_per_second(const SweepResult& r) {
  return analysis::log10_growth_per_second(r.measured_log_growth, r.input.device.period_s);
}

Figure sweep_figure(const std::vector<SweepResult>& results) {
  Figure f;
  f.name = "stability_sweep";
  f.title =
      "Stiff and extreme cases: growth predicted by the analysis against growth measured in a time-domain "
      "run\n"
      "g = log10(amplitude factor per second); axes sign(g) log10(1 + |g|); marginal: |pole| within 1e-6 of "
      "1";
  f.x = {"predicted sign(g) log10(1 + |g|)", false, ""};
  f.y = {"measured sign(g) log10(1 + |g|)", false, ""};
  f.data.columns = {"case",
                    "family",
                    "name",
                    "mode",
                    "scene",
                    "period_s",
                    "predicted_radius",
                    "predicted_log_growth_per_period",
                    "predicted_log10_growth_per_s",
                    "measured_log_growth_per_period",
                    "measured_log10_growth_per_s",
                    "tolerance_per_period",
                    "periods_run",
                    "predicted_axis",
                    "measured_axis",
                    "gate",
                    "agreement",
                    "why",
                    "note",
                    "gate_reason"};
  int id = 0;
  for (const SweepResult& r : results) {
    f.data.rows.push_back({static_cast<double>(++id),
                           r.input.family,
                           r.input.name,
                           std::string(r.input.mode == analysis::SweepMode::held ? "held" : "released"),
                           r.input.scene,
                           r.input.device.period_s,
                           r.predicted_radius,
                           r.ran ? r.predicted_log_growth : NAN,
                           r.ran ? predicted_per_second(r) : NAN,
                           r.ran ? r.measured_log_growth : NAN,
                           r.ran ? measured_per_second(r) : NAN,
                           r.tolerance,
                           static_cast<double>(r.periods_run),
                           r.ran ? signed_log(predicted_per_second(r)) : NAN,
                           r.ran ? signed_log(measured_per_second(r)) : NAN,
                           r.gate_decision,
                           std::string(analysis::to_string(r.agreement)),
                           r.why,
                           r.run_note,
                           r.gate_reason});
  }
  f.decorations = {"set arrow from graph 0, graph 0 to graph 1, graph 1 nohead lc rgb '#999999' dt 2",
                   "set size ratio -1", "set xzeroaxis lc rgb '#bbbbbb'", "set yzeroaxis lc rgb '#bbbbbb'"};
  f.curves.push_back({"agree",
                      {{"agreement", std::string("agree")}},
                      "predicted_axis",
                      "measured_axis",
                      "points pt 7 ps 1.0 lc rgb '#1b9e77'"});
  f.curves.push_back({"marginal (not judged)",
                      {{"agreement", std::string("marginal")}},
                      "predicted_axis",
                      "measured_axis",
                      "points pt 6 ps 1.2 lc rgb '#7570b3'"});
  f.curves.push_back({"NaN/Inf read (growth before the fault)",
                      {{"agreement", std::string("fault")}},
                      "predicted_axis",
                      "measured_axis",
                      "points pt 4 ps 1.2 lc rgb '#e6ab02'"});
  f.curves.push_back({"DISAGREE",
                      {{"agreement", std::string("DISAGREE")}},
                      "predicted_axis",
                      "measured_axis",
                      "points pt 3 ps 2.5 lw 3 lc rgb 'red'"});
  f.key = "inside left top";
  return f;
}

Maps compute_maps(bool quick, const OperatingPoint& op, analysis::StudyProgress& progress) {
  Maps m;
  m.wall = analysis::wall_region_map(map_delays, quick ? 24 : 60, progress);
  m.passivity = analysis::passivity_region_map(op.device_beta(), map_delays, quick ? 24 : 60);
  m.integrators = analysis::integrator_region_map(
      std::vector<world::Integrator>(world::all_integrators.begin(), world::all_integrators.end()),
      quick ? 8 : 24, progress);
  m.critical =
      analysis::critical_stiffness_curves(m.critical_period_s, 8e-3, quick ? 1e-3 : 0.1e-3, progress);
  return m;
}

/// Colgate & Schenkel beside Hulin: what a device damping b allows.
void print_passivity(std::ostream& out, const OperatingPoint& op) {
  out << "Passivity (Colgate & Schenkel) on a device damping b = " << fmt(op.device_damping)
      << " N s/m: b T / m = " << fmt(op.device_beta()) << "\n";
  TextTable table({"d", "passive alpha at beta = 0", "passive beta up to", "K at B = 0 (N/m)"});
  for (int d = 0; d <= map_delays; ++d) {
    const double alpha = analysis::passive_alpha_max(0.0, op.device_beta(), d);
    table.row({std::to_string(d), fmt(alpha), fmt(op.device_beta()),
               fmt(analysis::physical_stiffness(alpha, op.mass, op.period_s))});
  }
  table.print(out);
  const analysis::PassivityVerdict v = op.passivity();
  out << "  operating point: needs b >= " << fmt(v.bound.required_damping)
      << " N s/m to be passive: " << (v.passive ? "passive" : "NOT PASSIVE")
      << " on b = " << fmt(op.device_damping) << " N s/m; the largest passive K at B = " << fmt(op.damping)
      << " N s/m is " << fmt(v.max_stiffness) << " N/m"
      << (v.max_stiffness > 0.0 ? "" : " (B alone needs b >= B)") << "\n\n";
}

void print_maps(std::ostream& out, const Maps& m, const OperatingPoint& op) {
  out << "Hulin's wall region (normalized: alpha = K T^2 / m, beta = B T / m)\n";
  TextTable wall({"d", "alpha_max", "beta there", "beta_max (alpha -> 0)"});
  for (const auto& p : m.wall.maximum_stiffness) {
    wall.row({std::to_string(p.delay), fmt(p.alpha), fmt(p.beta),
              fmt(analysis::beta_max_at_zero_stiffness(p.delay))});
  }
  wall.print(out);
  out << "  operating point: alpha = " << fmt(op.alpha()) << ", beta = " << fmt(op.beta())
      << ", d = " << op.delay << ": "
      << (analysis::wall_stable(op.alpha(), op.beta(), op.delay) ? "stable" : "UNSTABLE") << "\n\n";
  print_passivity(out, op);
  out << "Integrators (spring scene, device held): stable w_n T range at zeta = 0 and the zeta band at w_n T "
         "= 1\n";
  TextTable integ({"integrator", "zeta = 0: stable for w_n T below", "w_n T = 1: stable zeta"});
  const analysis::AccuracyCase wheel = analysis::default_case(analysis::AccuracyScene::spring_wheel, 1e-3);
  for (const world::Integrator i : world::all_integrators) {
    std::string band = "none";
    for (const auto& r : m.integrators) {
      if (r.integrator == i && std::abs(r.wn_t - 1.0) < 1e-9) {
        band =
            fmt(r.zeta_lower) + " .. " + (std::isinf(r.zeta_upper) ? std::string("1e3+") : fmt(r.zeta_upper));
      }
    }
    const double top = analysis::stability_limit(wheel, {analysis::Method::Kind::integrator, i, 0.0}, 1e-3);
    integ.row({std::string(world::to_string(i)),
               top == 0.0 ? "unstable" : (std::isinf(top) ? "none (all)" : fmt(top)), band});
  }
  integ.print(out);
  out << "\nCritical stiffness K_CR (N/m) against loop delay, T = " << fmt_duration(m.critical_period_s)
      << "\n";
  TextTable kcr({"td", "rigid", "two-mass motor", "two-mass body"});
  for (int ms = 0; ms <= 8; ++ms) {
    std::vector<std::string> row{std::to_string(ms) + " ms"};
    for (const auto& [plant, sensor] :
         {std::pair{"rigid", world::Sensor::motor}, std::pair{"two-mass", world::Sensor::motor},
          std::pair{"two-mass", world::Sensor::body}}) {
      for (const auto& r : m.critical) {
        if (r.plant == plant && r.sensor == sensor && std::abs(r.delay_s - ms * 1e-3) < 1e-12)
          row.push_back(fmt(r.k_cr));
      }
    }
    kcr.row(row);
  }
  kcr.print(out);
  out << "\n";
}

std::string sweep_line(const SweepResult& r) {
  if (!r.ran) return r.predicted_verdict.starts_with("cannot assess") ? "cannot assess" : r.predicted_verdict;
  return r.predicted_verdict + " r = " + fmt(r.predicted_radius);
}

void print_sweep(std::ostream& out, const std::vector<SweepResult>& results) {
  int disagreements = 0;
  for (const auto& r : results) disagreements += r.agreement == SweepAgreement::disagree;
  if (disagreements > 0) {
    out << disagreements << " case(s) where prediction, run and gate disagree:\n";
    for (const auto& r : results) {
      if (r.agreement != SweepAgreement::disagree) continue;
      out << "  " << r.input.family << ": " << r.input.name << " on " << r.input.device.describe() << "\n"
          << "    " << r.why << "\n    predicted: " << (r.ran ? sweep_line(r) : r.predicted_verdict)
          << "; run: " << r.run_note << "\n    gate: " << r.gate_decision << ": " << r.gate_reason << "\n";
    }
    out << "\n";
  }
  out << "Sweep: growth in log10(amplitude factor) per second; predicted from the poles, measured in the "
         "run\n";
  TextTable table({"#", "family", "case", "predicted", "log10/s", "measured", "gate", "result"});
  int id = 0;
  for (const auto& r : results) {
    table.row({std::to_string(++id), r.input.family, r.input.name, sweep_line(r),
               r.ran ? sci(predicted_per_second(r)) : "-", r.ran ? sci(measured_per_second(r)) : "-",
               r.gate_decision, std::string(analysis::to_string(r.agreement))});
  }
  table.print(out);
}

nlohmann::json sweep_json(const std::vector<SweepResult>& results) {
  nlohmann::json out = nlohmann::json::array();
  const auto number = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); };
  for (const auto& r : results) {
    out.push_back({{"family", r.input.family},
                   {"name", r.input.name},
                   {"scene", r.input.scene},
                   {"device", r.input.device.describe()},
                   {"mode", r.input.mode == analysis::SweepMode::held ? "held" : "released"},
                   {"predicted", r.predicted_verdict},
                   {"predicted_radius", number(r.predicted_radius)},
                   {"predicted_log10_growth_per_s", r.ran ? number(predicted_per_second(r)) : nullptr},
                   {"measured_log10_growth_per_s", r.ran ? number(measured_per_second(r)) : nullptr},
                   {"tolerance_per_period", number(r.tolerance)},
                   {"periods_run", r.periods_run},
                   {"run", r.run_note},
                   {"gate", r.gate_decision},
                   {"gate_reason", r.gate_reason},
                   {"agreement", analysis::to_string(r.agreement)},
                   {"why", r.why}});
  }
  return out;
}

/// The operating point of the wall map, from the flags.
OperatingPoint operating_point_flags(const StabilityArgs& a) {
  OperatingPoint op;
  op.mass = positive_number("--mass", a.mass, "kg");
  op.period_s = positive_duration("--period", a.period);
  op.delay = whole_number("--delay", a.delay, 0, map_delays);
  op.stiffness = non_negative_number("--stiffness", a.stiffness, "N/m");
  op.damping = non_negative_number("--damping", a.damping, "N s/m");
  op.device_damping = non_negative_number("--device-damping", a.device_damping, "N s/m");
  return op;
}

/// The maps, the sweep's results and how long the sweep took.
struct StabilityRun {
  Maps maps;
  std::vector<SweepResult> results;
  double sweep_seconds = 0.0;
};

/// Computes the maps, then runs the sweep; analysis::StudyCancelled on Ctrl-C.
StabilityRun compute_stability(bool quick, const OperatingPoint& op, analysis::StudyProgress& progress) {
  StabilityRun run;
  run.maps = compute_maps(quick, op, progress);
  const auto sweep_start = std::chrono::steady_clock::now();
  run.results = analysis::run_stability_sweep(analysis::sweep_cases(quick), {}, progress);
  run.sweep_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - sweep_start).count();
  return run;
}

void write_stability_figures(FigureWriter& writer, const StabilityRun& run, const OperatingPoint& op) {
  writer.write(wall_figure(run.maps, op));
  writer.write(integrator_figure(run.maps));
  writer.write(critical_figure(run.maps));
  writer.write(sweep_figure(run.results));
}

int count_disagreements(const std::vector<SweepResult>& results) {
  int disagreements = 0;
  for (const auto& r : results) disagreements += r.agreement == SweepAgreement::disagree;
  return disagreements;
}

/// Hulin's largest stable stiffness at each delay, and the damping there.
nlohmann::json wall_maxima_json(const Maps& maps) {
  nlohmann::json wall = nlohmann::json::array();
  for (const auto& p : maps.wall.maximum_stiffness) {
    wall.push_back({{"delay", p.delay},
                    {"alpha_max", p.alpha},
                    {"beta_at_alpha_max", p.beta},
                    {"beta_max_at_zero_stiffness", analysis::beta_max_at_zero_stiffness(p.delay)}});
  }
  return wall;
}

/// K_CR against the delay for each plant and sensor (null where it is not finite).
nlohmann::json critical_stiffness_json(const Maps& maps) {
  nlohmann::json critical = nlohmann::json::array();
  for (const auto& r : maps.critical) {
    critical.push_back({{"plant", r.plant},
                        {"sensor", world::to_string(r.sensor)},
                        {"delay_s", r.delay_s},
                        {"k_cr", std::isfinite(r.k_cr) ? nlohmann::json(r.k_cr) : nlohmann::json(nullptr)}});
  }
  return critical;
}

/// Colgate & Schenkel on the device damping: the passive maxima and the operating point's verdict.
nlohmann::json passivity_report_json(const OperatingPoint& op) {
  const analysis::PassivityVerdict passivity = op.passivity();
  nlohmann::json passive_maxima = nlohmann::json::array();
  for (int d = 0; d <= map_delays; ++d)
    passive_maxima.push_back(
        {{"delay", d}, {"alpha_at_zero_beta", analysis::passive_alpha_max(0.0, op.device_beta(), d)}});
  return {{"device_damping", op.device_damping},
          {"device_beta", op.device_beta()},
          {"maxima", passive_maxima},
          {"operating_point",
           {{"required_damping", passivity.bound.required_damping},
            {"frequency_hz", passivity.bound.frequency_hz},
            {"passive", passivity.passive},
            {"max_stiffness", passivity.max_stiffness}}}};
}

/// --json's output: the maps' tables, the sweep and the files written.
nlohmann::json stability_json(const StabilityRun& run, const OperatingPoint& op, int disagreements,
                              double elapsed, const std::vector<std::filesystem::path>& written) {
  nlohmann::json out{{"wall_maxima", wall_maxima_json(run.maps)},
                     {"critical_stiffness", critical_stiffness_json(run.maps)},
                     {"sweep", sweep_json(run.results)},
                     {"cases", run.results.size()},
                     {"disagreements", disagreements},
                     {"sweep_seconds", run.sweep_seconds},
                     {"elapsed_s", elapsed},
                     {"files", nlohmann::json::array()}};
  for (const auto& f : written) out["files"].push_back(f.string());
  out["passivity"] = passivity_report_json(op);
  return out;
}

int run_stability(const StabilityArgs& a) {
  const OperatingPoint op = operating_point_flags(a);
  ReportSession session;
  StagedFiles files = open_output(a.out);
  analysis::StudyProgress progress = session.progress("report stability");
  const auto start = std::chrono::steady_clock::now();
  StabilityRun run;
  try {
    run = compute_stability(a.quick, op, progress);
  } catch (const analysis::StudyCancelled&) {
    return session.stopped();
  }
  progress.stage("drawing");
  FigureWriter writer(files);
  write_stability_figures(writer, run, op);
  if (ReportSession::interrupted()) return session.stopped();
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const auto written = files.commit();
  session.end_progress();
  writer.report_problems(files.dir());
  const int disagreements = count_disagreements(run.results);
  if (a.json) {
    std::cout << stability_json(run, op, disagreements, elapsed, written).dump(1) << "\n";
  } else {
    print_maps(std::cout, run.maps, op);
    print_sweep(std::cout, run.results);
    std::cout << "\n"
              << run.results.size() << " cases, " << disagreements << " disagreement(s); sweep "
              << fmt(run.sweep_seconds) << " s, report " << fmt(elapsed) << " s; wrote " << written.size()
              << " files to " << files.dir().string() << "\n";
  }
  if (disagreements > 0) {
    std::cerr << "hapticctl: " << disagreements << " sweep case(s) disagree (listed first)\n";
    return exit_refused;
  }
  return writer.failures().empty() ? exit_ok : exit_refused;
}

}  // namespace

void add_report_stability(CLI::App& report) {
  auto args = std::make_shared<StabilityArgs>();
  auto* cmd = report.add_subcommand(
      "stability",
      "Stability maps (Hulin's wall region, integrator regions, K_CR against delay) and a sweep of stiff and "
      "extreme cases: analysis, time-domain run and the daemon's gate for each; exit 1 on a disagreement");
  cmd->add_option("--out", args->out, "output directory (created if needed)")->capture_default_str();
  cmd->add_flag("--json", args->json, "print the sweep as one JSON object instead of tables");
  cmd->add_flag("--quick", args->quick, "a subset of the sweep and coarser maps, for the test suite");
  cmd->add_option("--mass", args->mass, "operating point on the wall map: device mass, kg")
      ->capture_default_str();
  cmd->add_option("--period", args->period, "... period (s, ms, us)")->capture_default_str();
  cmd->add_option("--delay", args->delay, "... delay d, samples (0..8)")->capture_default_str();
  cmd->add_option("--stiffness", args->stiffness, "... wall stiffness K, N/m")->capture_default_str();
  cmd->add_option("--damping", args->damping, "... wall damping B, N s/m")->capture_default_str();
  cmd->add_option("--device-damping", args->device_damping,
                  "the device's physical damping b for the passivity boundary, N s/m")
      ->capture_default_str();
  cmd->callback([args] {
    const int code = run_stability(*args);
    if (code != exit_ok) throw hapticctl::Exit(code);
  });
}

}  // namespace hapticd::cli
