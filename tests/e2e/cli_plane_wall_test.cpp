// End-to-end: `hapticctl analyze plane-wall`, the real binary: along the
// normal of a 2-axis stage the limit is exactly `analyze wall`'s with m_n;
// the pantograph's worst case over its workspace; usage errors name the flag.

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "support.hpp"

namespace hapticd::e2e::cli_plane_wall_test {
namespace {

using nlohmann::json;

/// Every digit: the same double on the other side of the command line.
std::string exact_text(double x) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", x);
  return text;
}

json run_json(std::vector<std::string> args) {
  args.push_back("--json");
  const CommandResult r = run(hapticctl_binary(), args);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return json::parse(r.out);
}

TEST(CliPlaneWall, AlongTheNormalOfAStageTheLimitIsTheOneAxisWallsWithMn) {
  for (const auto& [normal, mass] :
       std::vector<std::pair<std::string, double>>{{"1,1", 1.0 / (0.5 / 0.1 + 0.5 / 0.3)},
                                                   {"1,0", 0.1},
                                                   {"0,-1", 0.3},
                                                   {"1,2", 1.0 / (0.2 / 0.1 + 0.8 / 0.3)}}) {
    const json plane = run_json({"analyze", "plane-wall", "--normal", normal, "--axis-mass", "0.1,0.3",
                                 "--period", "1ms", "--delay", "1"});
    EXPECT_NEAR(plane["mass_along_normal"].get<double>(), mass, 1e-12 * mass) << normal;
    EXPECT_TRUE(plane["exact"].get<bool>());
    const json wall =
        run_json({"analyze", "wall", "--mass", exact_text(mass), "--period", "1ms", "--delay", "1"});
    EXPECT_NEAR(plane["k_max"].get<double>(), wall["k_max"].get<double>(), 1e-6 * wall["k_max"].get<double>())
        << normal;
  }
  const json bound = run_json({"analyze", "plane-wall", "--normal", "1,1", "--axis-mass", "0.1,0.3",
                               "--axis-damping", "0.2,0.3", "--period", "1ms", "--delay", "1"});
  EXPECT_FALSE(bound["exact"].get<bool>());
  EXPECT_NE(bound["basis"].get<std::string>().find("a bound"), std::string::npos);
}

TEST(CliPlaneWall, ThePantographIsJudgedAtItsWorstConfiguration) {
  const json p = run_json({"analyze", "plane-wall", "--normal", "0,1", "--pantograph",
                           "0.07,0.09,0.09,0.07,0.0381", "--joint-inertia", "2e-4,2e-4", "--workspace",
                           "-0.02,0.06,0.07,0.12", "--period", "1ms", "--delay", "0"});
  EXPECT_FALSE(p["exact"].get<bool>());
  ASSERT_TRUE(p.contains("worst_configuration")) << p.dump();
  const double y = p["worst_configuration"]["position"][1].get<double>();
  EXPECT_GE(y, 0.07 - 1e-12);
  EXPECT_LE(y, 0.12 + 1e-12);
  EXPECT_GT(p["mass_along_normal"].get<double>(), 0.0);
}

TEST(CliPlaneWall, BadArgumentsAreUsageErrorsNamingTheFlag) {
  const auto letter = run(hapticctl_binary(), {"analyze", "plane-wall", "--normal", "1,x", "--axis-mass",
                                               "1,1", "--period", "1ms", "--delay", "0"});
  EXPECT_EQ(letter.exit_code, 2);
  EXPECT_NE(letter.err.find("--normal: 'x' is not accepted; expected a finite number"), std::string::npos)
      << letter.err;
  const auto sizes = run(hapticctl_binary(), {"analyze", "plane-wall", "--normal", "1,1", "--axis-mass",
                                              "1,1,1", "--period", "1ms", "--delay", "0"});
  EXPECT_EQ(sizes.exit_code, 2);
  EXPECT_NE(sizes.err.find("--axis-mass: '1,1,1' is not accepted; expected 2 comma-separated numbers"),
            std::string::npos)
      << sizes.err;
  const auto reach =
      run(hapticctl_binary(), {"analyze", "plane-wall", "--normal", "0,1", "--pantograph",
                               "0.07,0.09,0.09,0.07,0.0381", "--joint-inertia", "2e-4,2e-4", "--workspace",
                               "-0.02,0.06,0.07,0.5", "--period", "1ms", "--delay", "0"});
  EXPECT_EQ(reach.exit_code, 2);
  EXPECT_NE(reach.err.find("--workspace: the workspace point"), std::string::npos) << reach.err;
  const auto neither = run(hapticctl_binary(),
                           {"analyze", "plane-wall", "--normal", "1,1", "--period", "1ms", "--delay", "0"});
  EXPECT_EQ(neither.exit_code, 2);
}

}  // namespace
}  // namespace hapticd::e2e::cli_plane_wall_test
