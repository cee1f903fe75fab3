// hapticctl report passivity: transparency (force error against the ideal
// wall) and the passivity controller's added damping against the wall's
// stiffness, with passivity off and with the controller
// (analysis/passivity_study.hpp); two figures and the table behind them.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "analysis/passivity_study.hpp"
#include "cli/analyze_common.hpp"
#include "cli/arguments.hpp"
#include "cli/report.hpp"
#include "cli/report_figure.hpp"
#include "cli/usage_error.hpp"
#include "cli/verbs.hpp"

namespace hapticd::cli {

// Named: a unity build puts this file beside analyze_passivity.cpp.
namespace passivity_report {
namespace {

using analysis::PassivityRunSummary;
using analysis::PassivityStudy;
using analysis::PassivityStudyRow;

struct PassivityArgs {
  std::string out = "hapticd-report";
  bool json = false;
  std::string mass = "0.1", period = "1ms", damping = "46", delay = "1";
  std::string factors = "0.5,0.8,1,1.5,2,3,5";
};

std::vector<double> factor_list(const std::string& text) {
  std::vector<double> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    out.push_back(positive_number("--factors", item, "times the fixed-gain limit"));
    if (out.back() > 1e3)
      throw UsageError("--factors: '" + item + "' is not accepted; expected factors from > 0 to 1000");
  }
  if (out.empty()) throw UsageError("--factors: give at least one factor, e.g. 0.5,1,2");
  return out;
}

constexpr const char* off_colour = "#d95f02";
constexpr const char* controller_colour = "#1b9e77";

/// The x range around the factors (log axis), e.g. [0.4:6.25] for 0.5 .. 5.
std::string factor_range(const PassivityStudy& s) {
  double low = s.gate_factor, high = s.gate_factor;
  for (const PassivityStudyRow& r : s.rows) {
    low = std::min({low, r.factor, 1.0});
    high = std::max({high, r.factor, 1.0});
  }
  return "[" + fmt(0.8 * low) + ":" + fmt(1.25 * high) + "]";
}

std::string mode_name(bool controller) { return controller ? "controller" : "off"; }

DataTable study_data(const PassivityStudy& s) {
  DataTable t;
  t.columns = {"passivity",    "factor",     "stiffness",      "push_force",    "static_penetration",
               "rms_error",    "peak_error", "rms_relative",   "peak_relative", "mean_damping",
               "peak_damping", "peak_force", "late_amplitude", "late_ratio",    "verdict"};
  for (const bool controller : {false, true}) {
    for (const PassivityStudyRow& r : s.rows) {
      const PassivityRunSummary& x = controller ? r.controller : r.off;
      t.rows.push_back({mode_name(controller), r.factor, r.stiffness, r.push_force, r.static_penetration,
                        x.rms_error, x.peak_error, x.rms_relative, x.peak_relative, x.mean_damping,
                        x.peak_damping, x.peak_force, x.late_amplitude, x.late_ratio,
                        std::string(analysis::to_string(x.verdict))});
    }
  }
  return t;
}

std::string setup_text(const PassivityStudy& s) {
  const auto& o = s.options;
  return "Hulin's wall (B = " + fmt(o.damping) + " N s/m, d = " + std::to_string(o.delay) +
         ") on m = " + fmt(o.mass) + " kg, T = " + fmt_duration(o.period_s) +
         "; fixed-gain limit K_limit = " + fmt(s.fixed_gain_limit) + " N/m";
}

std::vector<std::string> limit_marks(const PassivityStudy& s) {
  std::string ticks;
  for (const PassivityStudyRow& r : s.rows) ticks += (ticks.empty() ? "" : ", ") + fmt(r.factor);
  return {"set format x '%g'",
          "set xtics (" + ticks + ")",
          "set arrow from 1, graph 0 to 1, graph 1 nohead lc rgb '#999999' dt 2",
          "set label 'fixed-gain limit' at 1, graph 0.04 right offset -0.5,0 tc rgb '#666666'",
          "set arrow from " + fmt(s.gate_factor) + ", graph 0 to " + fmt(s.gate_factor) +
              ", graph 1 nohead lc rgb '#7570b3' dt 4 lw 1.5",
          "set label \"gate's factor " + fmt(s.gate_factor) + " x\" at " + fmt(s.gate_factor) +
              ", graph 0.04 left offset 0.5,0 tc rgb '#7570b3'"};
}

/// Off runs that did not stay bounded, drawn over the off curve.
void add_unbounded_marks(Figure& f, const std::string& y) {
  f.curves.push_back({"off: growing",
                      {{"passivity", std::string("off")}, {"verdict", std::string("growing")}},
                      "factor",
                      y,
                      "points pt 6 ps 2 lw 2 lc rgb 'red'"});
  f.curves.push_back({"off: diverged (until the run stopped at |y| > 1 m)",
                      {{"passivity", std::string("off")}, {"verdict", std::string("diverged")}},
                      "factor",
                      y,
                      "points pt 2 ps 2 lw 2 lc rgb 'red'"});
}

Figure transparency_figure(const PassivityStudy& s) {
  Figure f;
  f.name = "passivity_transparency";
  f.title = "Transparency: force error against the ideal wall F = -K y during the held push (" +
            fmt(s.options.window_start_s) + " s .. release), relative to the hand's push\n" + setup_text(s) +
            "; hand " + fmt(s.options.hand.stiffness) + " N/m, " + fmt(s.options.hand.damping) +
            " N s/m pulling to " + fmt(s.options.hand.reference * 1e3) + " mm";
  f.x = {"wall stiffness K / K_{limit}", true, factor_range(s)};
  f.y = {"force error / push force (RMS solid, peak dashed)", true, ""};
  f.data = study_data(s);
  for (const bool controller : {false, true}) {
    const std::string mode = mode_name(controller);
    const std::string c = std::string("lc rgb '") + (controller ? controller_colour : off_colour) + "'";
    f.curves.push_back({"passivity " + mode + ": RMS",
                        {{"passivity", mode}},
                        "factor",
                        "rms_relative",
                        "linespoints pt 7 lw 2 " + c});
    f.curves.push_back({"passivity " + mode + ": peak",
                        {{"passivity", mode}},
                        "factor",
                        "peak_relative",
                        "linespoints pt 5 dt 2 lw 1.5 " + c});
  }
  add_unbounded_marks(f, "rms_relative");
  f.decorations = limit_marks(s);
  f.key = "inside left top";
  f.command = "hapticctl report passivity";
  f.meta = {
      {"fixed_gain_limit", s.fixed_gain_limit},
      {"gate_factor", s.gate_factor},
      {"error", "F[n] - F_ideal(y[n]), F_ideal = -K y for y > 0, else 0; relative to K k_h r / (K + k_h)"}};
  return f;
}

Figure damping_figure(const PassivityStudy& s) {
  Figure f;
  f.name = "passivity_damping";
  f.title = "Damping the passivity controller adds during the held push (" + fmt(s.options.window_start_s) +
            " s .. release): mean (solid) and peak (dashed) alpha\nat most passivity_max_damping = " +
            fmt(s.max_damping) + " N s/m\n" + setup_text(s);
  f.x = {"wall stiffness K / K_{limit}", true, factor_range(s)};
  f.y = {"added damping alpha (N s/m)", false, "[0:" + fmt(1.15 * s.max_damping) + "]"};
  f.data = study_data(s);
  const std::string c = std::string("lc rgb '") + controller_colour + "'";
  f.curves.push_back({"controller: mean alpha",
                      {{"passivity", std::string("controller")}},
                      "factor",
                      "mean_damping",
                      "linespoints pt 7 lw 2 " + c});
  f.curves.push_back({"controller: peak alpha",
                      {{"passivity", std::string("controller")}},
                      "factor",
                      "peak_damping",
                      "linespoints pt 5 dt 2 lw 1.5 " + c});
  f.decorations = limit_marks(s);
  f.decorations.push_back("set arrow from graph 0, first " + fmt(s.max_damping) + " to graph 1, first " +
                          fmt(s.max_damping) + " nohead lc rgb '#666666' dt 3");
  f.decorations.push_back("set label 'passivity_max_damping' at graph 0.02, first " + fmt(s.max_damping) +
                          " offset 0,0.6 tc rgb '#666666' noenhanced");
  f.key = "inside left center";
  f.command = "hapticctl report passivity";
  f.meta = {{"fixed_gain_limit", s.fixed_gain_limit},
            {"gate_factor", s.gate_factor},
            {"max_damping", s.max_damping}};
  return f;
}

/// "bounded", "growing", "diverged at 0.714 s".
std::string verdict_cell(const PassivityRunSummary& x) {
  std::string text = analysis::to_string(x.verdict);
  if (x.run.diverged) text += " at " + fmt(x.run.diverged_at_s) + " s";
  return text;
}

std::string number_or_dash(double value) { return std::isfinite(value) ? fmt(value) : "-"; }

std::string factor_cell(const PassivityStudy& s, double factor) {
  return fmt(factor) + (std::abs(factor - s.gate_factor) < 1e-12 ? " *" : "");
}

void print_table(std::ostream& out, const PassivityStudy& s) {
  const auto& o = s.options;
  out << "Passivity report: " << setup_text(s) << " (physical_stiffness(alpha_max(beta, d), m, T))\n"
      << "Hand: " << fmt(o.hand.stiffness) << " N/m, " << fmt(o.hand.damping)
      << " N s/m pulling the device from "
      << "1 mm outside to " << fmt(o.hand.reference * 1e3) << " mm past the surface, letting go at "
      << fmt(o.hand.release_s) << " s. Measured from " << fmt(o.window_start_s) << " s to the release.\n"
      << "err/push: RMS of F[n] - F_ideal(y[n]) (F_ideal = -K y inside, 0 outside) over the push force K k_h "
         "r / (K "
         "+ "
         "k_h); late/static: oscillation amplitude over the push's last 0.1 s / static penetration\n\n";
  TextTable table({"K (N/m)", "K/limit", "push (N)", "off: err/push", "off: peak |F| (N)", "off",
                   "ctrl: err/push", "ctrl: peak |F| (N)", "alpha mean", "alpha peak", "late/static",
                   "ctrl"});
  for (const PassivityStudyRow& r : s.rows) {
    table.row({fmt(r.stiffness), factor_cell(s, r.factor), fmt(r.push_force), sci(r.off.rms_relative),
               number_or_dash(r.off.peak_force), verdict_cell(r.off), sci(r.controller.rms_relative),
               number_or_dash(r.controller.peak_force), number_or_dash(r.controller.mean_damping),
               number_or_dash(r.controller.peak_damping), sci(r.controller.late_ratio),
               verdict_cell(r.controller)});
  }
  table.print(out);
  out << "  * the gate's factor: `scene.set` accepts a wall up to " << fmt(s.gate_factor)
      << " x the fixed-gain limit (" << fmt(s.gate_factor * s.fixed_gain_limit)
      << " N/m) with passivity = controller; alpha in N s/m (at most passivity_max_damping = "
      << fmt(s.max_damping) << "); no torque limit in the simulation\n";
}

nlohmann::json summary_json(const PassivityRunSummary& x) {
  const auto number = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  return {{"verdict", analysis::to_string(x.verdict)},
          {"rms_error", number(x.rms_error)},
          {"peak_error", number(x.peak_error)},
          {"rms_relative", number(x.rms_relative)},
          {"peak_relative", number(x.peak_relative)},
          {"mean_damping", number(x.mean_damping)},
          {"peak_damping", number(x.peak_damping)},
          {"peak_force", number(x.peak_force)},
          {"late_amplitude", number(x.late_amplitude)},
          {"late_ratio", number(x.late_ratio)},
          {"run_peak_damping", number(x.run.peak_passivity_damping)},
          {"diverged_at_s", x.run.diverged ? nlohmann::json(x.run.diverged_at_s) : nlohmann::json(nullptr)}};
}

nlohmann::json study_json(const PassivityStudy& s, const std::vector<std::filesystem::path>& written) {
  const auto& o = s.options;
  nlohmann::json rows = nlohmann::json::array();
  for (const PassivityStudyRow& r : s.rows) {
    rows.push_back({{"factor", r.factor},
                    {"stiffness", r.stiffness},
                    {"push_force", r.push_force},
                    {"static_penetration", r.static_penetration},
                    {"off", summary_json(r.off)},
                    {"controller", summary_json(r.controller)}});
  }
  nlohmann::json out{{"mass_kg", o.mass},
                     {"period_s", o.period_s},
                     {"damping", o.damping},
                     {"delay", o.delay},
                     {"fixed_gain_limit", s.fixed_gain_limit},
                     {"gate_factor", s.gate_factor},
                     {"max_damping", s.max_damping},
                     {"window_start_s", o.window_start_s},
                     {"release_s", o.hand.release_s},
                     {"rows", rows},
                     {"files", nlohmann::json::array()}};
  for (const auto& f : written) out["files"].push_back(f.string());
  return out;
}

int run_passivity(const PassivityArgs& a) {
  analysis::PassivityStudyOptions options;
  options.mass = positive_number("--mass", a.mass, "kg");
  options.period_s = period_flag(a.period);
  options.damping = non_negative_number("--damping", a.damping, "N s/m");
  options.delay = whole_number("--delay", a.delay, 0, 16);
  options.factors = factor_list(a.factors);
  ReportSession session;
  PassivityStudy study;  // milliseconds: no progress line
  try {
    study = analysis::passivity_study(options);
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("report passivity: ") + e.what());
  }
  if (ReportSession::interrupted()) return session.stopped();
  StagedFiles files = open_output(a.out);
  FigureWriter writer(files);
  writer.write(transparency_figure(study));
  writer.write(damping_figure(study));
  if (ReportSession::interrupted()) return session.stopped();
  const auto written = files.commit();
  writer.report_problems(files.dir());
  if (a.json) {
    std::cout << study_json(study, written).dump(1) << "\n";
  } else {
    print_table(std::cout, study);
    std::cout << "\nwrote " << written.size() << " files to " << files.dir().string() << "\n";
  }
  return writer.failures().empty() ? exit_ok : exit_refused;
}

}  // namespace
}  // namespace passivity_report

void add_report_passivity(CLI::App& report) {
  auto args = std::make_shared<passivity_report::PassivityArgs>();
  auto* cmd = report.add_subcommand(
      "passivity",
      "Transparency (force error against the ideal wall) and the passivity controller's added damping "
      "against the wall's stiffness, with passivity off and with the controller (a hand pushing Hulin's "
      "device into the wall and letting go)");
  cmd->add_option("--out", args->out, "output directory (created if needed)")->capture_default_str();
  cmd->add_flag("--json", args->json, "print the study as one JSON object instead of the table");
  cmd->add_option("--mass", args->mass, "device mass m, kg")->capture_default_str();
  cmd->add_option("--period", args->period, "period T (s, ms, us)")->capture_default_str();
  cmd->add_option("--damping", args->damping, "wall damping B, N s/m")->capture_default_str();
  cmd->add_option("--delay", args->delay, "wall delay d, samples (0..16)")->capture_default_str();
  cmd->add_option("--factors", args->factors,
                  "wall stiffnesses as factors of the fixed-gain limit, comma-separated")
      ->capture_default_str();
  cmd->callback([args] {
    const int code = passivity_report::run_passivity(*args);
    if (code != exit_ok) throw hapticctl::Exit(code);
  });
}

}  // namespace hapticd::cli
