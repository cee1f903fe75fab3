// hapticctl analyze integrator: numerical stability of a spring scene's
// discretization (Freudenberg 2.8-2.15).

#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "analysis/integrator_stability.hpp"
#include "cli/analyze_common.hpp"
#include "cli/arguments.hpp"
#include "cli/usage_error.hpp"
#include "world/text.hpp"

namespace hapticd::cli {

namespace {

struct IntegratorArgs {
  std::string scheme, stiffness, inertia, mass, period, damping;
  // Given at all (an empty value given is an error, not the default).
  CLI::Option* inertia_flag = nullptr;
  CLI::Option* mass_flag = nullptr;
  CLI::Option* damping_flag = nullptr;
  bool json = false;
};

double damping_of(const IntegratorArgs& a, const analysis::SpringScene& scene) {
  if (a.damping_flag->count() == 0) return 0.0;
  // "auto" is Freudenberg's b = T k (eq. 2.24), as in the scene's parameter.
  if (a.damping == "auto") return scene.period_s * scene.stiffness;
  return non_negative_number("--damping", a.damping, "N m s/rad or N s/m, or auto");
}

void run_integrator(const IntegratorArgs& a) {
  const auto scheme = world::parse_integrator(a.scheme);
  if (!scheme) {
    throw UsageError("--scheme: '" + a.scheme + "' is not accepted; expected one of " +
                     std::string(world::integrator_names()));
  }
  const bool inertia_given = a.inertia_flag->count() > 0;
  if (inertia_given == (a.mass_flag->count() > 0)) {
    throw UsageError(
        "--inertia: give the virtual inertia (kg m^2), or --mass (kg) for a spring-mass, not both");
  }
  analysis::SpringScene scene;
  scene.integrator = *scheme;
  scene.stiffness = non_negative_number("--stiffness", a.stiffness, "N m/rad or N/m");
  scene.inertia = inertia_given ? positive_number("--inertia", a.inertia, "kg m^2")
                                : positive_number("--mass", a.mass, "kg");
  scene.period_s = period_flag(a.period);
  scene.damping = damping_of(a, scene);
  const auto v = analysis::analyze_integrator(scene);
  const bool assessed = v.verdict.assessed();
  const double wn = std::sqrt(scene.stiffness / scene.inertia);
  if (a.json) {
    nlohmann::json eig = nlohmann::json::array();
    for (const auto& e : v.eigenvalues) eig.push_back({e.real(), e.imag()});
    const nlohmann::json maybe_null = nullptr;
    std::cout << nlohmann::json{{"scheme", world::to_string(*scheme)},
                                {"stiffness", scene.stiffness},
                                {"inertia", scene.inertia},
                                {"damping", scene.damping},
                                {"period", scene.period_s},
                                {"natural_frequency_hz", wn / (2.0 * M_PI)},
                                {"eigenvalues", eig},
                                {"eigenvalue_magnitude",
                                 assessed ? nlohmann::json(v.eigenvalue_magnitude) : maybe_null},
                                {"verdict", analysis::to_string(v.verdict.state)},
                                {"reason", assessed ? maybe_null : nlohmann::json(v.verdict.reason)},
                                {"stable", v.stable()},
                                {"marginal", v.marginal()},
                                // null when it overflows a double; the log10 is always finite
                                {"growth_per_second", v.growth_per_second},
                                {"growth_per_second_log10", v.growth_per_second_log10}}
                     .dump(2)
              << "\n";
  } else {
    Table t;
    t.row("scheme", std::string(world::to_string(*scheme)));
    t.row("scene", "k = " + fmt(scene.stiffness) + ", J = " + fmt(scene.inertia) +
                       ", b = " + fmt(scene.damping) + ", T = " + fmt_duration(scene.period_s) +
                       " (f_n = " + fmt(wn / (2.0 * M_PI)) + " Hz)");
    if (assessed) {
      t.row("|lambda| max", world::text::format_fixed(v.eigenvalue_magnitude, 12));  // 1 - 1e-12 shows
      t.row("verdict",
            v.marginal() ? "marginal (neither grows nor decays)" : (v.stable() ? "stable" : "UNSTABLE"));
      t.row("amplitude after 1 s", std::isfinite(v.growth_per_second)
                                       ? "x" + fmt(v.growth_per_second)
                                       : "x1e" + fmt(v.growth_per_second_log10) + " (overflows a double)");
    } else {
      t.row("verdict", "cannot assess (see below)");
    }
    t.print(std::cout);
  }
  if (!assessed) throw CannotAssess(v.verdict.reason);
}

}  // namespace

void add_analyze_integrator(CLI::App& analyze) {
  auto args = std::make_shared<IntegratorArgs>();
  auto* cmd = analyze.add_subcommand("integrator",
                                     "Eigenvalues of a discretized spring scene (Freudenberg 2.8-2.15)");
  cmd->add_option("--scheme", args->scheme, "forward-euler, semi-implicit-euler, trapezoid, rk4, exact")
      ->required();
  cmd->add_option("--stiffness", args->stiffness, "spring k, N m/rad (or N/m)")->required();
  args->inertia_flag = cmd->add_option("--inertia", args->inertia, "virtual inertia J_w, kg m^2");
  args->mass_flag = cmd->add_option("--mass", args->mass, "virtual mass m, kg (spring-mass)");
  cmd->add_option("--period", args->period, "sampling period, 1 us to 1 s (s, ms, us)")->required();
  args->damping_flag = cmd->add_option(
      "--damping", args->damping, "damping b (default 0), or auto: Freudenberg's fix b = T k (eq. 2.24)");
  cmd->add_flag("--json", args->json, "print one JSON object");
  cmd->callback([args] { run_integrator(*args); });
}

}  // namespace hapticd::cli
