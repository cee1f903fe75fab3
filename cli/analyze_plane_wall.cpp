// hapticctl analyze plane-wall: a plane wall on a device with several axes,
// judged along its normal with the mass it pushes there
// (analysis/task_space.hpp), then by Hulin's region for that mass.

#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "analysis/task_space.hpp"
#include "analysis/wall_stability.hpp"
#include "cli/analyze_common.hpp"
#include "cli/arguments.hpp"
#include "cli/usage_error.hpp"

namespace hapticd::cli {

namespace {

struct PlaneWallArgs {
  std::string normal, axis_mass, axis_damping, pantograph, joint_inertia, joint_damping, workspace;
  std::string period, delay, stiffness, damping;
  bool json = false;
};

/// "1,1" -> {1, 1}: `count` numbers (or 1 to 6 when count is 0), each checked by `check`.
std::vector<double> number_list(std::string_view flag, const std::string& text, std::size_t count,
                                double (*check)(std::string_view, const std::string&, std::string_view),
                                std::string_view unit) {
  std::vector<double> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) out.push_back(check(flag, item, unit));
  const bool sized = count == 0 ? out.size() >= 1 && out.size() <= 6 : out.size() == count;
  if (!sized)
    throw UsageError(std::string(flag) + ": '" + text + "' is not accepted; expected " +
                     (count == 0 ? std::string("1 to 6") : std::to_string(count)) +
                     " comma-separated numbers (" + std::string(unit) + ")");
  return out;
}

double any_number(std::string_view flag, const std::string& text, std::string_view unit) {
  try {
    return text.starts_with('-') ? -non_negative_number(flag, text.substr(1), unit)
                                 : non_negative_number(flag, text, unit);
  } catch (const UsageError&) {
    throw UsageError(std::string(flag) + ": '" + text + "' is not accepted; expected a finite number (" +
                     std::string(unit) + ")");
  }
}

std::vector<analysis::JointModel> joints(const std::vector<double>& masses,
                                         const std::vector<double>& damping) {
  std::vector<analysis::JointModel> out;
  for (std::size_t i = 0; i < masses.size(); ++i)
    out.push_back({masses[i], damping.empty() ? 0.0 : damping[i]});
  return out;
}

world::AxisVector axis_vector(const std::vector<double>& values) {
  world::AxisVector v(static_cast<Eigen::Index>(values.size()));
  for (std::size_t i = 0; i < values.size(); ++i) v(static_cast<Eigen::Index>(i)) = values[i];
  return v;
}

analysis::DirectionalModel directional_model(const PlaneWallArgs& a) {
  const auto normal = number_list("--normal", a.normal, 0, any_number, "a direction");
  if (!a.axis_mass.empty()) {
    const auto masses = number_list("--axis-mass", a.axis_mass, normal.size(), positive_number, "kg");
    const auto damping = a.axis_damping.empty() ? std::vector<double>{}
                                                : number_list("--axis-damping", a.axis_damping, normal.size(),
                                                              non_negative_number, "N s/m");
    return analysis::cartesian_along(joints(masses, damping), axis_vector(normal));
  }
  if (normal.size() != 2) throw UsageError("--normal: the pantograph is planar: give 2 numbers");
  const auto links = number_list("--pantograph", a.pantograph, 5, positive_number, "m: a1,a2,a3,a4,a5");
  const auto inertia = number_list("--joint-inertia", a.joint_inertia, 2, positive_number, "kg m^2");
  const auto damping = a.joint_damping.empty() ? std::vector<double>{}
                                               : number_list("--joint-damping", a.joint_damping, 2,
                                                             non_negative_number, "N m s/rad");
  const auto box = number_list("--workspace", a.workspace, 4, any_number, "m: x_min,x_max,y_min,y_max");
  world::PantographGeometry g;
  g.a1 = links[0], g.a2 = links[1], g.a3 = links[2], g.a4 = links[3], g.a5 = links[4];
  try {
    return analysis::pantograph_along(world::PantographKinematics(g), joints(inertia, damping),
                                      axis_vector(normal), {box[0], box[1], box[2], box[3]});
  } catch (const std::invalid_argument& e) {
    throw UsageError(std::string("--workspace: ") + e.what());
  }
}

void run_plane_wall(const PlaneWallArgs& a) {
  if (a.axis_mass.empty() == a.pantograph.empty())
    throw UsageError(
        "give either --axis-mass (a Cartesian stage) or --pantograph with --joint-inertia and "
        "--workspace");
  const analysis::DirectionalModel along = directional_model(a);
  const double period = period_flag(a.period);
  const int delay = whole_number("--delay", a.delay, 0, 64);
  const auto stiffness = optional_non_negative("--stiffness", a.stiffness, "N/m");
  const auto damping = optional_non_negative("--damping", a.damping, "N s/m");
  const auto wall = analysis::analyze_wall(along.mass, period, delay, stiffness, damping);
  nlohmann::json out{{"mass_along_normal", along.mass},
                     {"damping_along_normal", along.damping},
                     {"exact", along.exact},
                     {"basis", along.basis},
                     {"k_max", wall.k_max},
                     {"b_at_k_max", wall.b_at_k_max}};
  if (along.position.size() == 2 && !a.pantograph.empty())
    out["worst_configuration"] = {{"position", {along.position(0), along.position(1)}},
                                  {"joints", {along.joints(0), along.joints(1)}}};
  if (stiffness || damping) out["stable"] = wall.verdict.assessed() ? nlohmann::json(wall.stable()) : nullptr;
  if (a.json) {
    std::cout << out.dump(2) << "\n";
  } else {
    Table t;
    t.row("along the normal", fmt(along.mass) + " kg, " + fmt(along.damping) + " N s/m (" +
                                  (along.exact ? "exact" : "a bound") + ")");
    t.row("how", along.basis);
    if (stiffness || damping)
      t.row("verdict", !wall.verdict.assessed() ? "cannot assess" : wall.stable() ? "stable" : "UNSTABLE");
    t.row("largest K along n",
          fmt(wall.k_max) + " N/m with B = " + fmt(wall.b_at_k_max) +
              " N s/m (Hulin, the one-axis wall with this mass; device damping left out)");
    t.print(std::cout);
  }
  if ((stiffness || damping) && !wall.verdict.assessed()) throw CannotAssess(wall.verdict.reason);
}

}  // namespace

void add_analyze_plane_wall(CLI::App& analyze) {
  auto a = std::make_shared<PlaneWallArgs>();
  auto* c = analyze.add_subcommand(
      "plane-wall",
      "A plane wall on a device with several axes, judged along its normal (m_n = 1/(n^T J M^-1 J^T n))");
  c->add_option("--normal", a->normal, "the wall's normal, comma-separated (1,1 or 0,0,1)")->required();
  c->add_option("--axis-mass", a->axis_mass, "a Cartesian stage: each axis' mass, kg (0.1,0.3)");
  c->add_option("--axis-damping", a->axis_damping, "each axis' damping to ground, N s/m (default 0)");
  c->add_option("--pantograph", a->pantograph, "a five-bar pantograph: a1,a2,a3,a4,a5 in m");
  c->add_option("--joint-inertia", a->joint_inertia, "the pantograph's motor inertias, kg m^2 (I1,I2)");
  c->add_option("--joint-damping", a->joint_damping, "the motors' damping, N m s/rad (default 0)");
  c->add_option("--workspace", a->workspace, "the box judged, m: x_min,x_max,y_min,y_max");
  c->add_option("--period", a->period, "sampling period, 1 us to 1 s (s, ms, us)")->required();
  c->add_option("--delay", a->delay, "output delay d, whole samples 0 to 64")->required();
  c->add_option("--stiffness", a->stiffness, "wall stiffness K, N/m");
  c->add_option("--damping", a->damping, "wall damping B, N s/m");
  c->add_flag("--json", a->json, "print one JSON object");
  c->callback([a] { run_plane_wall(*a); });
}

}  // namespace hapticd::cli
