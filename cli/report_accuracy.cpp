// hapticctl report accuracy: error against run time of every linear scene
// and integrator (analysis/accuracy_study.hpp), with Boost.Odeint as the
// outside reference; three figures per scene and the tables behind them.

#include <chrono>
#include <cmath>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <numbers>

#include "analysis/accuracy_study.hpp"
#include "cli/analyze_common.hpp"
#include "cli/arguments.hpp"
#include "cli/report.hpp"
#include "cli/report_figure.hpp"
#include "cli/usage_error.hpp"
#include "cli/verbs.hpp"

namespace hapticd::cli {

namespace {

using analysis::AccuracyCase;
using analysis::AccuracyScene;
using analysis::AccuracyStudy;
using analysis::Method;

struct AccuracyArgs {
  std::string out = "hapticd-report";
  bool json = false;
  bool quick = false;
  std::vector<std::string> scenes;
  std::string period = "1ms";
  std::string periods, duration, cycles;
  std::string stiffness, inertia, mass, damping, step, delay, device_mass, device_damping;
};

struct AccuracyUnits {
  std::string stiffness, inertia, damping, step, scale;
};

AccuracyUnits accuracy_units(AccuracyScene scene) {
  switch (scene) {
    case AccuracyScene::spring_mass:
      return {"N/m", "kg", "N s/m", "m", "k z_0"};
    case AccuracyScene::wall:
      return {"N/m", "kg", "N s/m", "N", "F_h"};
    default:
      return {"N m/rad", "kg m^2", "N m s/rad", "rad", "k z_0"};
  }
}

std::string describe(const AccuracyCase& c) {
  const AccuracyUnits u = accuracy_units(c.scene);
  std::string s;
  if (c.scene == AccuracyScene::wall) {
    s = "K = " + fmt(c.stiffness) + " N/m, B = " + fmt(c.damping) +
        " N s/m, d = " + std::to_string(c.delay_samples) + " on m = " + fmt(c.device.mass) + " kg";
    if (c.device.damping > 0) s += " (b = " + fmt(c.device.damping) + " N s/m)";
    s += ", pushed with F_h = " + fmt(c.step) + " N";
  } else {
    s = "k = " + fmt(c.stiffness) + " " + u.stiffness + ", " +
        (c.scene == AccuracyScene::spring_mass ? "m" : "J") + " = " + fmt(c.inertia) + " " + u.inertia +
        ", b = " + fmt(c.damping) + " " + u.damping;
    if (c.damping > 0) s += c.scene == AccuracyScene::spring_wheel_absolute ? " (absolute)" : " (relative)";
    s += ", step z0 = " + fmt(c.step) + " " + u.step;
  }
  return s + "; w_n = " + fmt(analysis::natural_frequency(c)) +
         " rad/s, zeta = " + fmt(analysis::damping_ratio(c));
}

bool any_parameter(const AccuracyArgs& a) {
  for (const std::string* s : {&a.stiffness, &a.inertia, &a.mass, &a.damping, &a.step, &a.delay,
                               &a.device_mass, &a.device_damping}) {
    if (!s->empty()) return true;
  }
  return false;
}

/// The one selected case with the scene and device flags applied.
void apply_parameters(const AccuracyArgs& a, AccuracyCase& c, double device_period) {
  const bool wall = c.scene == AccuracyScene::wall;
  const bool wheel = !wall && c.scene != AccuracyScene::spring_mass;
  const auto only = [&](const std::string& value, std::string_view flag, bool allowed, std::string_view who) {
    if (!value.empty() && !allowed) {
      throw UsageError(std::string(flag) + ": not a parameter of " +
                       std::string(analysis::to_string(c.scene)) + "; it applies to " + std::string(who));
    }
  };
  only(a.inertia, "--inertia", wheel, "the spring-wheel scenes (use --mass for spring-mass)");
  only(a.mass, "--mass", c.scene == AccuracyScene::spring_mass,
       "spring-mass (the wall's device: --device-mass)");
  only(a.delay, "--delay", wall, "the wall");
  only(a.device_mass, "--device-mass", wall, "the wall");
  only(a.device_damping, "--device-damping", wall, "the wall");
  const AccuracyUnits u = accuracy_units(c.scene);
  if (!a.stiffness.empty()) c.stiffness = positive_number("--stiffness", a.stiffness, u.stiffness);
  if (!a.inertia.empty()) c.inertia = positive_number("--inertia", a.inertia, "kg m^2");
  if (!a.mass.empty()) c.inertia = positive_number("--mass", a.mass, "kg");
  if (!a.damping.empty()) {
    // "auto" is Freudenberg's b = T k (2.24) at the device period, as in the scene catalog.
    c.damping = a.damping == "auto" && !wall ? device_period * c.stiffness
                                             : non_negative_number("--damping", a.damping, u.damping);
  }
  if (!a.step.empty()) c.step = positive_number("--step", a.step, u.step);
  if (!a.delay.empty()) c.delay_samples = whole_number("--delay", a.delay, 0, 16);
  if (!a.device_mass.empty()) c.device.mass = positive_number("--device-mass", a.device_mass, "kg");
  if (!a.device_damping.empty()) {
    c.device.damping = non_negative_number("--device-damping", a.device_damping, "N s/m");
  }
}

analysis::AccuracyStudyOptions build_options(const AccuracyArgs& a) {
  const double device_period = positive_duration("--period", a.period);
  analysis::AccuracyStudyOptions o = analysis::default_accuracy_options(device_period);
  if (a.quick) {
    o.periods_s = {100e-6, 1e-3, 10e-3};
    o.durations_s = {1, 10};
    o.wn_t = analysis::log_grid(1e-3, std::numbers::pi, 4);
    o.tolerances = {1e-3, 1e-6, 1e-9, 1e-12};
    o.growth_tolerances = {1e-6};
    o.timing_steps = 1L << 14;
  }
  if (!a.scenes.empty()) {
    o.cases.clear();
    for (const std::string& name : a.scenes) {
      const auto scene = analysis::parse_accuracy_scene(name);
      if (!scene) {
        throw UsageError("--scene: '" + name +
                         "' is not accepted; expected spring-wheel, spring-wheel-absolute, "
                         "spring-wheel-relative, spring-mass or wall");
      }
      o.cases.push_back(analysis::default_case(*scene, device_period));
    }
  }
  if (any_parameter(a)) {
    if (o.cases.size() != 1) {
      throw UsageError("scene parameters (--stiffness, --damping, ...) need exactly one --scene to apply to");
    }
    apply_parameters(a, o.cases.front(), device_period);
  }
  if (!a.periods.empty()) o.periods_s = duration_list("--periods", a.periods);
  if (std::find(o.periods_s.begin(), o.periods_s.end(), device_period) == o.periods_s.end()) {
    o.periods_s.push_back(device_period);  // figure 2 is drawn from the runs at the device period
  }
  std::sort(o.periods_s.begin(), o.periods_s.end());
  if (!a.duration.empty()) {
    const double d = positive_duration("--duration", a.duration);
    o.durations_s.clear();
    for (double t = 1.0; t < d * (1 - 1e-12); t *= 10.0) o.durations_s.push_back(t);
    o.durations_s.push_back(d);
  }
  if (!a.cycles.empty()) o.sweep_cycles = positive_number("--cycles", a.cycles, "natural periods");
  return o;
}

std::string scene_name(const AccuracyCase& c) { return std::string(analysis::to_string(c.scene)); }

std::string method_title(const Method& m) {
  if (m.kind == Method::Kind::sampled_wall) return "sampled wall (ZOH device, backward difference, delay)";
  return m.name();
}

double last_duration(const AccuracyStudy& s) { return s.options.durations_s.back(); }

std::string duration_text(double seconds) { return fmt_duration(seconds); }

std::string tolerance_text(double tolerance) {
  char buffer[16];
  std::snprintf(buffer, sizeof buffer, "%.0e", tolerance);
  return buffer;
}

std::vector<Method> methods_of(const AccuracyStudy& s, AccuracyScene scene) {
  std::vector<Method> out;
  for (const auto& r : s.work_precision) {
    if (r.scene != scene || r.method.kind == Method::Kind::odeint_dopri5) continue;
    bool seen = false;
    for (const Method& m : out) seen = seen || m.label() == r.method.label();
    if (!seen) out.push_back(r.method);
  }
  return out;
}

Figure work_precision_figure(const AccuracyStudy& s, const AccuracyCase& c) {
  const AccuracyUnits u = accuracy_units(c.scene);
  Figure f;
  f.name = "accuracy_work_precision_" + scene_name(c);
  f.title = scene_name(c) + ": error against run time, " + duration_text(last_duration(s)) + " simulated\n" +
            describe(c) + "\nT = " + duration_text(s.options.periods_s.front()) + " .. " +
            duration_text(s.options.periods_s.back()) + " (one point per T; open symbols: unstable)";
  f.x = {"CPU time per simulated second (s/s)", true, ""};
  f.y = {"largest |F - F_{exact}| / " + u.scale + " over " + duration_text(last_duration(s)), true, ""};
  f.data.columns = {"method",     "tolerance", "period_s",       "wn_t",
                    "duration_s", "error",     "cpu_s_per_step", "cpu_s_per_simulated_s",
                    "stable"};
  // Grouped by duration, then method: each curve's rows are contiguous, so
  // gnuplot draws its line without gaps.
  for (std::size_t i = 0; i < s.options.durations_s.size(); ++i) {
    for (const auto& r : s.work_precision) {
      if (r.scene != c.scene) continue;
      f.data.rows.push_back({r.method.name(), r.method.tolerance, r.period_s, r.wn_t,
                             s.options.durations_s[i], r.run.errors[i], r.run.cpu_s_per_step,
                             r.run.cpu_s_per_simulated_s, r.run.stable});
    }
  }
  const double d = last_duration(s);
  for (const Method& m : methods_of(s, c.scene)) {
    const std::string colour = colour_for(m.name());
    f.curves.push_back({method_title(m),
                        {{"method", m.name()}, {"duration_s", d}, {"stable", true}},
                        "cpu_s_per_simulated_s",
                        "error",
                        "linespoints pt 7 ps 1.1 lw 1.5 lc rgb '" + colour + "'"});
    f.curves.push_back({"",
                        {{"method", m.name()}, {"duration_s", d}, {"stable", false}},
                        "cpu_s_per_simulated_s",
                        "error",
                        "points pt 6 ps 1.4 lw 1.5 lc rgb '" + colour + "'"});
  }
  if (s.options.odeint && !s.options.tolerances.empty()) {
    f.curves.push_back({"odeint-dopri5, tol " + tolerance_text(s.options.tolerances.front()) + " .. " +
                            tolerance_text(s.options.tolerances.back()),
                        {{"method", std::string("odeint-dopri5")}, {"duration_s", d}},
                        "cpu_s_per_simulated_s",
                        "error",
                        "linespoints pt 5 ps 1.0 dt 2 lw 1.5 lc rgb '" + colour_for("odeint-dopri5") + "'"});
  }
  f.meta = {{"scene", scene_name(c)}, {"case", describe(c)}, {"error_unit", u.scale}};
  return f;
}

Figure growth_figure(const AccuracyStudy& s, const AccuracyCase& c) {
  const AccuracyUnits u = accuracy_units(c.scene);
  Figure f;
  f.name = "accuracy_error_growth_" + scene_name(c);
  f.title = scene_name(c) +
            ": error against simulated time at T = " + duration_text(s.options.device_period_s) + "\n" +
            describe(c);
  f.x = {"simulated time (s)", true, ""};
  f.y = {"largest |F - F_{exact}| / " + u.scale + " so far", true, ""};
  f.data.columns = {"method", "series", "tolerance", "period_s", "time_s", "error", "stable"};
  for (const auto& g : s.growth) {
    if (g.scene != c.scene) continue;
    for (const auto& p : g.run.growth) {
      f.data.rows.push_back({g.method.name(), g.method.label(), g.method.tolerance, g.period_s, p.time_s,
                             p.error, g.run.stable});
    }
  }
  std::vector<std::string> seen;
  for (const auto& g : s.growth) {
    if (g.scene != c.scene) continue;
    const std::string label = g.method.label();
    if (std::find(seen.begin(), seen.end(), label) != seen.end()) continue;
    seen.push_back(label);
    const bool dopri = g.method.kind == Method::Kind::odeint_dopri5;
    const bool dashed = dopri || g.method.kind == Method::Kind::odeint_rk4;
    f.curves.push_back({(g.method.kind == Method::Kind::sampled_wall ? method_title(g.method) : label) +
                            (g.run.stable ? "" : " (unstable)"),
                        {{"series", label}},
                        "time_s",
                        "error",
                        std::string("lines lw 2 ") + (dashed ? "dt 2 " : "") + "lc rgb '" +
                            // each dopri5 tolerance its own grey
                            (dopri && g.method.tolerance < s.options.growth_tolerances.front()
                                 ? std::string("#aaaaaa")
                                 : colour_for(g.method.name())) +
                            "'"});
  }
  f.meta = {{"scene", scene_name(c)}, {"case", describe(c)}, {"error_unit", u.scale}};
  return f;
}

Figure sweep_figure(const AccuracyStudy& s, const AccuracyCase& c) {
  const AccuracyUnits u = accuracy_units(c.scene);
  Figure f;
  f.name = "accuracy_error_vs_wnt_" + scene_name(c);
  const std::string cycles =
      fmt(s.options.sweep_cycles) + " natural period" + (s.options.sweep_cycles == 1 ? "" : "s");
  f.title = scene_name(c) + ": error over " + cycles +
            " against w_n T at T = " + duration_text(s.options.device_period_s) +
            ", damping ratio zeta = " + fmt(analysis::damping_ratio(c)) +
            " held\ndashed: derived leading error; dotted: stability limit; " + "open symbols: unstable";
  f.x = {"w_n T (rad per period)", true, "[8e-4:4]"};
  f.y = {"largest |F - F_{exact}| / " + u.scale + " over " + cycles, true, "[1e-17:1e2]"};
  f.data.columns = {"method", "wn_t", "error", "predicted", "stable", "stability_limit"};
  for (const auto& r : s.sweep) {
    if (r.scene != c.scene) continue;
    double limit = std::numeric_limits<double>::quiet_NaN();
    for (const auto& l : s.limits) {
      if (l.scene == c.scene && l.method.label() == r.method.label()) limit = l.wn_t;
    }
    f.data.rows.push_back({r.method.name(), r.wn_t, r.error, r.predicted, r.stable, limit});
  }
  int label_row = 0;
  for (const auto& l : s.limits) {
    if (l.scene != c.scene) continue;
    const Method& m = l.method;
    const std::string colour = colour_for(m.name());
    f.curves.push_back({method_title(m),
                        {{"method", m.name()}, {"stable", true}},
                        "wn_t",
                        "error",
                        "linespoints pt 7 ps 1.0 lw 1.5 lc rgb '" + colour + "'"});
    f.curves.push_back({"",
                        {{"method", m.name()}, {"stable", false}},
                        "wn_t",
                        "error",
                        "points pt 6 ps 1.3 lw 1.5 lc rgb '" + colour + "'"});
    bool predicted = false;
    for (const auto& r : s.sweep)
      predicted =
          predicted || (r.scene == c.scene && r.method.label() == m.label() && std::isfinite(r.predicted));
    if (predicted) {
      f.curves.push_back(
          {"", {{"method", m.name()}}, "wn_t", "predicted", "lines dt 2 lw 1.2 lc rgb '" + colour + "'"});
    }
    if (std::isfinite(l.wn_t) && l.wn_t > 0.0) {
      f.decorations.push_back("set arrow from " + fmt(l.wn_t) + ", graph 0 to " + fmt(l.wn_t) +
                              ", graph 1 nohead dt 3 lw 1.5 lc rgb '" + colour + "'");
      f.decorations.push_back("set label " + gnuplot_quote(m.name() + " limit " + fmt(l.wn_t)) + " at " +
                              fmt(l.wn_t) + ", graph " + fmt(0.06 + 0.07 * label_row++) +
                              " right offset -0.5,0 textcolor rgb '" + colour + "' noenhanced font ',9'");
    }
  }
  f.meta = {{"scene", scene_name(c)},
            {"case", describe(c)},
            {"error_unit", u.scale},
            {"cycles", s.options.sweep_cycles},
            {"note", "zeta held while the stiffness sets w_n T; predicted = derived leading-order error"}};
  return f;
}

nlohmann::json number(double x) { return std::isfinite(x) ? nlohmann::json(x) : nlohmann::json(nullptr); }

nlohmann::json study_json(const AccuracyStudy& s, double elapsed_s,
                          const std::vector<std::filesystem::path>& files) {
  nlohmann::json out;
  out["device_period_s"] = s.options.device_period_s;
  out["durations_s"] = s.options.durations_s;
  out["periods_s"] = s.options.periods_s;
  out["sweep_cycles"] = s.options.sweep_cycles;
  out["cases"] = nlohmann::json::array();
  for (const auto& c : s.options.cases) {
    out["cases"].push_back({{"scene", scene_name(c)},
                            {"stiffness", c.stiffness},
                            {"inertia", c.inertia},
                            {"damping", c.damping},
                            {"step", c.step},
                            {"delay_samples", c.delay_samples},
                            {"device_mass", c.device.mass},
                            {"natural_frequency_rad_per_s", analysis::natural_frequency(c)},
                            {"damping_ratio", analysis::damping_ratio(c)},
                            {"description", describe(c)}});
  }
  for (const auto& r : s.work_precision) {
    nlohmann::json errors = nlohmann::json::array();
    for (const double e : r.run.errors) errors.push_back(number(e));
    out["work_precision"].push_back({{"scene", std::string(analysis::to_string(r.scene))},
                                     {"method", r.method.name()},
                                     {"tolerance", number(r.method.tolerance)},
                                     {"period_s", r.period_s},
                                     {"wn_t", r.wn_t},
                                     {"errors", errors},
                                     {"cpu_s_per_step", number(r.run.cpu_s_per_step)},
                                     {"cpu_s_per_simulated_s", number(r.run.cpu_s_per_simulated_s)},
                                     {"solver_steps", r.run.solver_steps},
                                     {"stable", r.run.stable},
                                     {"contact_kept", r.run.contact_kept}});
  }
  for (const auto& r : s.sweep) {
    out["sweep"].push_back({{"scene", std::string(analysis::to_string(r.scene))},
                            {"method", r.method.name()},
                            {"wn_t", r.wn_t},
                            {"error", number(r.error)},
                            {"predicted", number(r.predicted)},
                            {"stable", r.stable}});
  }
  for (const auto& l : s.limits) {
    out["stability_limits"].push_back({{"scene", std::string(analysis::to_string(l.scene))},
                                       {"method", l.method.name()},
                                       {"wn_t", number(l.wn_t)},
                                       {"unlimited", std::isinf(l.wn_t)}});
  }
  for (const auto& o : s.orders) {
    out["orders"].push_back({{"scene", std::string(analysis::to_string(o.scene))},
                             {"method", o.method.name()},
                             {"points", o.points},
                             {"order", number(o.order)},
                             {"constant", number(o.constant)},
                             {"derived_order", o.predicted.order},
                             {"derived_constant", number(o.predicted.order ? o.predicted.constant : NAN)}});
  }
  out["elapsed_s"] = elapsed_s;
  out["files"] = nlohmann::json::array();
  for (const auto& f : files) out["files"].push_back(f.string());
  return out;
}

void print_case(std::ostream& out, const AccuracyStudy& s, const AccuracyCase& c) {
  const AccuracyUnits u = accuracy_units(c.scene);
  out << scene_name(c) << ": " << describe(c) << "\n";
  out << "  largest |F - F_exact| / " << u.scale << " over " << duration_text(last_duration(s))
      << " by period T (* unstable); CPU time per step of the scene alone\n";
  std::vector<std::string> header{"method"};
  for (const double t : s.options.periods_s) header.push_back(duration_text(t));
  header.push_back("ns/step");
  TextTable table(header);
  for (const Method& m : methods_of(s, c.scene)) {
    std::vector<std::string> row{m.name()};
    double ns = 0.0;
    for (const double t : s.options.periods_s) {
      for (const auto& r : s.work_precision) {
        if (r.scene == c.scene && r.method.label() == m.label() && r.period_s == t) {
          row.push_back(sci(r.run.errors.back()) + (r.run.stable ? " " : "*"));
          ns = r.run.cpu_s_per_step * 1e9;
        }
      }
    }
    row.push_back(fmt(ns));
    table.row(row);
  }
  table.print(out);
  if (s.options.odeint) {
    out << "  odeint-dopri5 observed every " << duration_text(s.options.device_period_s) << " (error over "
        << duration_text(s.options.durations_s.front()) << " and " << duration_text(last_duration(s))
        << ")\n";
    TextTable dopri({"tolerance", "error " + duration_text(s.options.durations_s.front()),
                     "error " + duration_text(last_duration(s)), "steps", "CPU s per simulated s"});
    for (const auto& r : s.work_precision) {
      if (r.scene != c.scene || r.method.kind != Method::Kind::odeint_dopri5) continue;
      dopri.row({sci(r.method.tolerance), sci(r.run.errors.front()), sci(r.run.errors.back()),
                 std::to_string(r.run.solver_steps), sci(r.run.cpu_s_per_simulated_s)});
    }
    dopri.print(out);
  }
  out << "  against w_n T (over " << fmt(s.options.sweep_cycles)
      << " natural period(s), zeta held): order found, "
      << "error / (w_n T)^p, derived, stability limit of w_n T\n";
  TextTable orders({"method", "order", "constant", "derived", "limit"});
  for (const auto& l : s.limits) {
    if (l.scene != c.scene) continue;
    std::vector<std::string> row{
        l.method.name(), "-", "-", "-",
        std::isinf(l.wn_t) ? "none" : (l.wn_t == 0 ? "unstable from 1e-3" : fmt(l.wn_t))};
    for (const auto& o : s.orders) {
      if (o.scene != c.scene || o.method.label() != l.method.label() || o.points < 3) continue;
      row[1] = fmt(o.order);
      row[2] = fmt(o.constant);
      if (o.predicted.order > 0)
        row[3] = "p = " + std::to_string(o.predicted.order) + ", " + fmt(o.predicted.constant);
    }
    if (l.method.kind == Method::Kind::integrator && l.method.integrator == world::Integrator::exact) {
      row[1] = "exact";
    }
    orders.row(row);
  }
  orders.print(out);
  out << "\n";
}

int run_accuracy(const AccuracyArgs& a) {
  const analysis::AccuracyStudyOptions options = build_options(a);
  ReportSession session;
  StagedFiles files = open_output(a.out);
  analysis::StudyProgress progress = session.progress("report accuracy");
  const auto start = std::chrono::steady_clock::now();
  AccuracyStudy study;
  try {
    study = analysis::run_accuracy_study(options, progress);
  } catch (const analysis::StudyCancelled&) {
    return session.stopped();
  }
  FigureWriter writer(files);
  for (const AccuracyCase& c : study.options.cases) {
    progress.stage("drawing " + scene_name(c));
    writer.write(work_precision_figure(study, c));
    writer.write(growth_figure(study, c));
    writer.write(sweep_figure(study, c));
    if (ReportSession::interrupted()) return session.stopped();
  }
  const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const auto written = files.commit();
  session.end_progress();
  writer.report_problems(files.dir());
  const int code = writer.failures().empty() ? exit_ok : exit_refused;
  if (a.json) {
    std::cout << study_json(study, elapsed, written).dump(1) << "\n";
    return code;
  }
  std::cout << "accuracy report: held step, device period " << duration_text(options.device_period_s) << ", "
            << duration_text(last_duration(study))
            << " simulated; error = largest |F[n] - F(nT)| against the "
            << "closed form of the held-input problem\n\n";
  for (const AccuracyCase& c : study.options.cases) print_case(std::cout, study, c);
  std::cout << "wrote " << written.size() << " files to " << files.dir().string() << " in " << fmt(elapsed)
            << " s\n";
  return code;
}

}  // namespace

void add_report_accuracy(CLI::App& report) {
  auto args = std::make_shared<AccuracyArgs>();
  auto* cmd = report.add_subcommand(
      "accuracy",
      "Error against CPU time of every linear scene and integrator on a held step (Freudenberg 2.3-2.4), "
      "with Boost.Odeint RK4 and dopri5 as references");
  cmd->add_option("--out", args->out, "output directory (created if needed)")->capture_default_str();
  cmd->add_flag("--json", args->json, "print the study as one JSON object instead of tables");
  cmd->add_flag("--quick", args->quick, "a small study (3 periods, 10 s, fewer points) for tests");
  cmd->add_option("--scene", args->scenes,
                  "spring-wheel, spring-wheel-absolute, spring-wheel-relative, spring-mass or wall "
                  "(repeat; default all)");
  cmd->add_option("--period", args->period, "device period for figures 2 and 3 (s, ms, us)")
      ->capture_default_str();
  cmd->add_option("--periods", args->periods, "periods of figure 1, comma-separated (default 20us .. 10ms)");
  cmd->add_option("--duration", args->duration,
                  "simulated time (default 100s; errors at 1 s, 10 s, ... too)");
  cmd->add_option("--cycles", args->cycles, "natural periods simulated per w_n T point (default 1)");
  cmd->add_option("--stiffness", args->stiffness, "k (N m/rad, N/m) or the wall's K (N/m)");
  cmd->add_option("--inertia", args->inertia, "virtual wheel inertia J, kg m^2");
  cmd->add_option("--mass", args->mass, "spring-mass virtual mass, kg");
  cmd->add_option("--damping", args->damping,
                  "b (N m s/rad, N s/m) or auto (b = T k), or the wall's B (N s/m)");
  cmd->add_option("--step", args->step, "held step: z0 (rad or m), or the hand's push on the wall F_h (N)");
  cmd->add_option("--delay", args->delay, "wall delay d, samples (0..16)");
  cmd->add_option("--device-mass", args->device_mass, "mass the wall is rendered on, kg");
  cmd->add_option("--device-damping", args->device_damping, "viscous damping of that device, N s/m");
  cmd->callback([args] {
    const int code = run_accuracy(*args);
    if (code != exit_ok) throw hapticctl::Exit(code);
  });
}

}  // namespace hapticd::cli
