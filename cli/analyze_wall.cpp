// hapticctl analyze wall / boundary: Hulin's virtual-wall stability region.

#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "analysis/passivity.hpp"
#include "analysis/wall_stability.hpp"
#include "cli/analyze_common.hpp"
#include "cli/arguments.hpp"
#include "cli/usage_error.hpp"

namespace hapticd::cli {

namespace {

struct WallArgs {
  std::string mass, period, delay, stiffness, damping;
  CLI::Option* stiffness_flag = nullptr;  ///< given at all (an empty value is an error, not "absent")
  CLI::Option* damping_flag = nullptr;
  bool json = false;
};

std::optional<double> optional_flag(const CLI::Option* flag, const std::string& text, std::string_view unit) {
  if (flag->count() == 0) return std::nullopt;
  return non_negative_number(flag->get_name(), text, unit);
}

void print_wall(const analysis::WallVerdict& v, bool have_point, bool have_stiffness);

void run_wall(const WallArgs& a) {
  const double mass = positive_number("--mass", a.mass, "kg");
  const double period = period_flag(a.period);
  const int delay = whole_number("--delay", a.delay, 0, 64);
  const auto stiffness = optional_flag(a.stiffness_flag, a.stiffness, "N/m");
  const auto damping = optional_flag(a.damping_flag, a.damping, "N s/m");
  const analysis::WallVerdict v = analysis::analyze_wall(mass, period, delay, stiffness, damping);

  nlohmann::json out{{"mass", mass},
                     {"period", period},
                     {"delay", delay},
                     {"alpha", v.alpha},
                     {"beta", v.beta},
                     {"alpha_max", v.alpha_max},
                     {"beta_at_alpha_max", v.beta_at_alpha_max},
                     {"k_max", v.k_max},
                     {"b_at_k_max", v.b_at_k_max},
                     {"beta_max_at_zero_stiffness", v.beta_max_at_zero_stiffness},
                     {"b_max_at_zero_stiffness", v.b_max_at_zero_stiffness}};
  const bool have_point = stiffness.has_value() || damping.has_value();
  const bool assessed = !have_point || v.verdict.assessed();
  if (have_point) {
    out["stiffness"] = v.stiffness;
    out["damping"] = v.damping;
    out["verdict"] = analysis::to_string(v.verdict.state);
    out["reason"] = assessed ? nlohmann::json(nullptr) : nlohmann::json(v.verdict.reason);
    out["stable"] = v.stable();
    out["pole_radius"] = assessed ? nlohmann::json(v.pole_radius) : nlohmann::json(nullptr);
    out["alpha_max_for_damping"] = v.alpha_max_for_damping;
    out["k_max_for_damping"] = v.k_max_for_damping;
  } else {
    out["verdict"] = nullptr;
    out["stable"] = nullptr;
  }
  if (stiffness) {
    out["damping_range"] = v.damping_range
                               ? nlohmann::json::array({v.damping_range->lower, v.damping_range->upper})
                               : nlohmann::json::array();
  }
  if (a.json) {
    std::cout << out.dump(2) << "\n";
  } else {
    print_wall(v, have_point, stiffness.has_value());
  }
  if (!assessed) throw CannotAssess(v.verdict.reason);
}

void print_wall(const analysis::WallVerdict& v, bool have_point, bool have_stiffness) {
  const double mass = v.mass_kg, period = v.period_s;
  const int delay = v.delay_samples;
  Table t;
  t.row("device", fmt(mass) + " kg, T = " + fmt_duration(period) + ", d = " + std::to_string(delay));
  if (have_point) {
    t.row("wall", "K = " + fmt(v.stiffness) + " N/m, B = " + fmt(v.damping) + " N s/m");
    t.row("normalized", "alpha = " + fmt(v.alpha) + ", beta = " + fmt(v.beta) + "  (Hulin eq. 2)");
    if (v.verdict.assessed()) {
      t.row("verdict", v.stable() ? "stable" : "UNSTABLE");
      t.row("pole radius", fmt(v.pole_radius));
      t.row("largest K at this B",
            fmt(v.k_max_for_damping) + " N/m (alpha = " + fmt(v.alpha_max_for_damping) + ")");
    } else {
      t.row("verdict", "cannot assess (see below)");
    }
  }
  if (have_stiffness) {
    t.row("stable B range",
          v.damping_range ? fmt(v.damping_range->lower) + " .. " + fmt(v.damping_range->upper) + " N s/m"
                          : std::string("none: no damping makes this K stable"));
  }
  t.row("largest K", fmt(v.k_max) + " N/m with B = " + fmt(v.b_at_k_max) + " N s/m (alpha = " +
                         fmt(v.alpha_max) + ", beta = " + fmt(v.beta_at_alpha_max) + ")");
  t.row("largest B at K = 0",
        fmt(v.b_max_at_zero_stiffness) + " N s/m (beta = " + fmt(v.beta_max_at_zero_stiffness) + ")");
  if (have_point && v.verdict.assessed() && !v.stable()) t.row("why", analysis::refusal_message(v));
  t.print(std::cout);
}

struct BoundaryArgs {
  std::string delay, points = "50";
  std::string device_damping, mass, period;  ///< the passivity boundary: all three, or none
  CLI::Option* device_option = nullptr;
  CLI::Option* mass_option = nullptr;
  CLI::Option* period_option = nullptr;
  bool json = false;
};

/// Colgate & Schenkel's boundary in the same plane, for a device damping b
/// normalized as Hulin's beta: b T / m.
struct PassivityCurve {
  double device_damping = 0.0, mass = 0.0, period = 0.0, device_beta = 0.0;
  std::vector<analysis::PassivityBoundaryPoint> points;
};

std::optional<PassivityCurve> passivity_curve(const BoundaryArgs& a, int delay, int points) {
  const int given = static_cast<int>(a.device_option->count() > 0) +
                    static_cast<int>(a.mass_option->count() > 0) +
                    static_cast<int>(a.period_option->count() > 0);
  if (given == 0) return std::nullopt;
  if (given != 3)
    throw UsageError(
        "--device-damping: the passivity boundary needs --device-damping, --mass and --period "
        "together (its beta is b T / m)");
  PassivityCurve c;
  c.device_damping = non_negative_number("--device-damping", a.device_damping, "N s/m");
  c.mass = positive_number("--mass", a.mass, "kg");
  c.period = period_flag(a.period);
  c.device_beta = analysis::normalized_damping(c.device_damping, c.mass, c.period);
  c.points = analysis::passivity_boundary(c.device_beta, delay, points);
  return c;
}

void run_boundary(const BoundaryArgs& a) {
  const int delay = whole_number("--delay", a.delay, 0, 64);
  const int points = whole_number("--points", a.points, 2, 100000);
  const auto passivity = passivity_curve(a, delay, points);
  const auto boundary = analysis::stability_boundary(delay, points);
  nlohmann::json list = nlohmann::json::array();
  for (const auto& p : boundary) list.push_back({p.beta, p.alpha});
  if (a.json) {
    nlohmann::json out{{"delay", delay}, {"points", list}};
    if (passivity) {
      nlohmann::json passive = nlohmann::json::array();
      for (const auto& p : passivity->points) passive.push_back({p.beta, p.alpha});
      out["passivity"] = {{"device_damping", passivity->device_damping},
                          {"mass", passivity->mass},
                          {"period", passivity->period},
                          {"device_beta", passivity->device_beta},
                          {"points", passive}};
    }
    std::cout << out.dump(2) << "\n";
    return;
  }
  std::cout << "# Hulin stability boundary, d = " << delay << ": beta alpha_max(beta)\n";
  for (const auto& p : boundary) std::cout << fmt(p.beta) << " " << fmt(p.alpha) << "\n";
  if (!passivity) return;
  std::cout << "\n\n# Colgate & Schenkel passivity boundary, d = " << delay
            << ", device damping b = " << fmt(passivity->device_damping) << " N s/m on "
            << fmt(passivity->mass) << " kg, T = " << fmt_duration(passivity->period)
            << " (b T/m = " << fmt(passivity->device_beta) << "): beta alpha_passive(beta)\n";
  if (passivity->points.empty()) std::cout << "# b = 0: only alpha = beta = 0 is passive\n";
  for (const auto& p : passivity->points) std::cout << fmt(p.beta) << " " << fmt(p.alpha) << "\n";
}

}  // namespace

void add_analyze_wall(CLI::App& analyze) {
  auto args = std::make_shared<WallArgs>();
  auto* wall = analyze.add_subcommand(
      "wall", "Virtual wall on a rigid mass (Hulin eq. 1-4): stability region, limits");
  wall->add_option("--mass", args->mass, "device mass, kg")->required();
  wall->add_option("--period", args->period, "sampling period, 1 us to 1 s (s, ms, us)")->required();
  wall->add_option("--delay", args->delay, "output delay d, whole samples 0 to 64")->required();
  args->stiffness_flag = wall->add_option("--stiffness", args->stiffness, "wall stiffness K, N/m");
  args->damping_flag = wall->add_option("--damping", args->damping, "wall damping B, N s/m");
  wall->add_flag("--json", args->json, "print one JSON object");
  wall->callback([args] { run_wall(*args); });

  auto bargs = std::make_shared<BoundaryArgs>();
  auto* boundary = analyze.add_subcommand(
      "boundary",
      "Points of the exact boundary alpha_max(beta) (Hulin Fig. 4-7), and the passivity boundary beside it");
  boundary->add_option("--delay", bargs->delay, "output delay d, whole samples 0 to 64")->required();
  boundary->add_option("--points", bargs->points, "number of points (default 50)");
  bargs->device_option = boundary->add_option(
      "--device-damping", bargs->device_damping,
      "with --mass and --period: also the passivity boundary for this device damping b, N s/m");
  bargs->mass_option = boundary->add_option("--mass", bargs->mass, "device mass m, kg (passivity: b T / m)");
  bargs->period_option =
      boundary->add_option("--period", bargs->period, "sampling period (s, ms, us) (passivity: b T / m)");
  boundary->add_flag("--json", bargs->json, "print one JSON object");
  boundary->callback([bargs] { run_boundary(*bargs); });
}

}  // namespace hapticd::cli
