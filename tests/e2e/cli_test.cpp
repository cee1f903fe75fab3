// End-to-end: the offline `hapticctl analyze` verbs, run as the real binary.
// No daemon is involved; these check the JSON contract (keys), a few exact
// values with closed forms, duration parsing, and one-line usage errors.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "support.hpp"

namespace hapticd::e2e::cli_test {
namespace {

using nlohmann::json;

json analyze(const std::vector<std::string>& args) {
  std::vector<std::string> full{"analyze"};
  full.insert(full.end(), args.begin(), args.end());
  full.push_back("--json");
  const CommandResult r = run(hapticctl_binary(), full);
  EXPECT_EQ(r.exit_code, 0) << r.err;
  return json::parse(r.out);
}

void expect_keys(const json& object, const std::vector<std::string>& keys) {
  ASSERT_TRUE(object.is_object()) << object.dump();
  for (const auto& k : keys)
    EXPECT_TRUE(object.contains(k)) << "missing key '" << k << "' in " << object.dump();
}

std::string exact(double x) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.17g", x);
  return buffer;
}

std::size_t line_count(const std::string& text) {
  std::size_t n = 0;
  for (char c : text) n += c == '\n' ? 1 : 0;
  if (!text.empty() && text.back() != '\n') ++n;
  return n;
}

TEST(CliAnalyze, IntegratorForwardEulerOneHertzWheel) {
  // Forward Euler on J = 1, k = (2 pi)^2 (f_n = 1 Hz): |lambda| = sqrt(1 + (w T)^2).
  const double k = 4.0 * M_PI * M_PI;
  const json out = analyze({"integrator", "--scheme", "forward-euler", "--stiffness", exact(k), "--inertia",
                            "1", "--period", "1ms"});
  expect_keys(out, {"eigenvalue_magnitude", "stable", "growth_per_second"});
  const double magnitude = std::sqrt(1.0 + k * 1e-6);
  EXPECT_NEAR(out["eigenvalue_magnitude"].get<double>(), magnitude, 1e-12);
  EXPECT_FALSE(out["stable"].get<bool>());
  EXPECT_NEAR(out["growth_per_second"].get<double>(), std::pow(magnitude, 1000.0), 1e-9);
  EXPECT_GT(out["growth_per_second"].get<double>(), 1.0);
}

TEST(CliAnalyze, WallKeysAndHulinLimits) {
  const json out = analyze(
      {"wall", "--mass", "0.1", "--period", "1ms", "--delay", "1", "--stiffness", "9000", "--damping", "46"});
  expect_keys(out, {"alpha", "beta", "stable", "pole_radius", "alpha_max", "beta_at_alpha_max", "k_max",
                    "b_at_k_max", "beta_max_at_zero_stiffness", "damping_range"});
  EXPECT_NEAR(out["alpha"].get<double>(), 0.09, 1e-12);
  EXPECT_NEAR(out["beta"].get<double>(), 0.46, 1e-12);
  EXPECT_TRUE(out["stable"].get<bool>());
  EXPECT_LT(out["pole_radius"].get<double>(), 1.0);
  const double alpha_max = out["alpha_max"].get<double>();
  EXPECT_NEAR(alpha_max, 0.144469, 1e-6);
  EXPECT_NEAR(out["k_max"].get<double>(), alpha_max * 0.1 / 1e-6, 1e-6 * alpha_max * 0.1 / 1e-6);
  ASSERT_TRUE(out["damping_range"].is_array());
  ASSERT_EQ(out["damping_range"].size(), 2u);
  EXPECT_LT(out["damping_range"][0].get<double>(), 46.0);
  EXPECT_GT(out["damping_range"][1].get<double>(), 46.0);

  const json d0 = analyze({"wall", "--mass", "0.1", "--period", "1ms", "--delay", "0"});
  EXPECT_NEAR(d0["alpha_max"].get<double>(), 12.0 - 8.0 * std::sqrt(2.0), 1e-9);
}

TEST(CliAnalyze, BoundaryIsAListOfBetaAlphaPairs) {
  const json out = analyze({"boundary", "--delay", "1", "--points", "20"});
  ASSERT_TRUE(out.contains("points"));
  ASSERT_TRUE(out["points"].is_array());
  ASSERT_EQ(out["points"].size(), 20u);
  double best_alpha = 0.0;
  for (const auto& p : out["points"]) {
    ASSERT_TRUE(p.is_array());
    ASSERT_EQ(p.size(), 2u);
    EXPECT_GE(p[0].get<double>(), 0.0);  // beta
    EXPECT_GE(p[1].get<double>(), 0.0);  // alpha
    best_alpha = std::max(best_alpha, p[1].get<double>());
  }
  // No boundary point lies above the wall's largest alpha for d = 1.
  EXPECT_LE(best_alpha, 0.144469 + 1e-6);
  EXPECT_GT(best_alpha, 0.1);
}

TEST(CliAnalyze, CriticalStiffnessKeys) {
  const json rigid = analyze({"critical-stiffness", "--plant", "rigid", "--period", "1ms", "--delay", "1ms"});
  expect_keys(rigid, {"k_cr", "crossover_hz", "gain_margin_db"});
  EXPECT_GT(rigid["k_cr"].get<double>(), 0.0);
  EXPECT_NEAR(rigid["gain_margin_db"].get<double>(), 20.0 * std::log10(rigid["k_cr"].get<double>()), 1e-6);
  const json two =
      analyze({"critical-stiffness", "--plant", "two-mass", "--period", "1ms", "--delay", "1ms"});
  expect_keys(two, {"k_cr", "crossover_hz", "gain_margin_db", "q_db"});
  EXPECT_GT(two["k_cr"].get<double>(), 0.0);

  // Rigid plant (Table I totals m = 5.4 kg, b = 3.5 N s/m), no delay: the
  // ZOH of 1/(m s^2 + b s) is (c1 z + c0) / (b (z - 1)(z - e)) with a = b/m,
  // e = e^{-a T}, c1 = T - (1 - e)/a, c0 = (1 - e)/a - T e. The loop
  // z^2 + a1 z + a0, a1 = K c1/b - 1 - e, a0 = e + K c0/b, reaches |z| = 1 as a
  // complex pair (Jury: a0 = 1) at K_cr = b (1 - e)/c0, where
  // cos(w T) = -a1/2. (Re-derived here, as in RigidNoDelayMatchesJuryClosedForm.)
  const json jury = analyze({"critical-stiffness", "--plant", "rigid", "--period", "1ms"});
  const double m = 5.4, b = 3.5, t = 1e-3, a = b / m, e = std::exp(-a * t);
  const double c1 = t - (1 - e) / a, c0 = (1 - e) / a - t * e;
  const double kcr = b * (1 - e) / c0;
  ASSERT_GT(2 * b * (1 + e) / (c1 - c0), kcr);  // the real root z = -1 stays inside up to there
  const double w = std::acos(-(kcr * c1 / b - 1 - e) / 2) / t;
  EXPECT_NEAR(jury["mass"].get<double>(), m, 1e-15);
  EXPECT_NEAR(jury["damping"].get<double>(), b, 1e-15);
  EXPECT_NEAR(jury["k_cr"].get<double>(), kcr, 1e-6 * kcr);
  EXPECT_NEAR(jury["crossover_rad_per_s"].get<double>(), w, 1e-6 * w);
  EXPECT_NEAR(jury["crossover_hz"].get<double>(), w / (2 * M_PI), 1e-6 * w / (2 * M_PI));
  EXPECT_NEAR(jury["gain_margin_db"].get<double>(), 20 * std::log10(kcr), 1e-6);
  EXPECT_NEAR(kcr, 2 * b / t, 0.01 * kcr);  // the familiar b > K T / 2

  // Two-mass: Q = m_m z_n w_n (eq. 24) from Table I with eq. 13-16:
  // w_n = sqrt(k_c m / (m_d m_m)) = 529.7058, z_n = (b_m + b_c)/m_m +
  // (b_d + b_c)/m_d - b/m = 53.29303, Q = 8468.97 N/m = 78.557 dB.
  const double m_m = 0.3, m_d = 5.1, b_m = 0.1, b_d = 3.4, k_c = 79.5e3, b_c = 15.0;
  const double wn = std::sqrt(k_c * (m_m + m_d) / (m_d * m_m));
  const double zn = (b_m + b_c) / m_m + (b_d + b_c) / m_d - (b_m + b_d) / (m_m + m_d);
  const double q_db = 20 * std::log10(m_m * zn * wn);
  EXPECT_NEAR(q_db, 78.557, 1e-3);
  EXPECT_NEAR(two["q_db"].get<double>(), q_db, 1e-9);
  EXPECT_NEAR(two["omega_n"].get<double>(), wn, 1e-9 * wn);
  EXPECT_NEAR(two["z_n"].get<double>(), zn, 1e-9 * zn);
}

TEST(CliAnalyze, DurationSpellingsAgree) {
  const json a = analyze({"wall", "--mass", "0.1", "--period", "1ms", "--delay", "1"});
  const json b = analyze({"wall", "--mass", "0.1", "--period", "0.001", "--delay", "1"});
  const json c = analyze({"wall", "--mass", "0.1", "--period", "1000us", "--delay", "1"});
  EXPECT_EQ(a, b);
  EXPECT_EQ(a, c);
  EXPECT_DOUBLE_EQ(a["period"].get<double>(), 0.001);
}

struct BadInput {
  std::vector<std::string> args;
  std::string flag;
};

TEST(CliAnalyze, InvalidInputsExitTwoWithOneLineNamingTheArgument) {
  const std::vector<BadInput> cases{
      {{"wall", "--mass", "0", "--period", "1ms", "--delay", "1"}, "--mass"},
      {{"wall", "--mass", "-1", "--period", "1ms", "--delay", "1"}, "--mass"},
      {{"wall", "--mass", "0.1", "--period", "nan", "--delay", "1"}, "--period"},
      {{"wall", "--mass", "0.1", "--period", "0", "--delay", "1"}, "--period"},
      {{"integrator", "--scheme", "bogus", "--stiffness", "1", "--inertia", "1", "--period", "1ms"},
       "--scheme"},
      {{"wall", "--mass", "0.1", "--period", "1ms", "--delay", "x"}, "--delay"},
      {{"wall", "--mass", "0.1", "--period", "1ms", "--delay", "1.5"}, "--delay"},
      {{"critical-stiffness", "--period", "1ms", "--delay", "-1ms"}, "--delay"},
  };
  for (const auto& c : cases) {
    std::vector<std::string> args{"analyze"};
    args.insert(args.end(), c.args.begin(), c.args.end());
    const CommandResult r = run(hapticctl_binary(), args);
    std::string joined;
    for (const auto& a : c.args) joined += a + " ";
    EXPECT_EQ(r.exit_code, 2) << joined << "\n" << r.err;
    EXPECT_EQ(line_count(r.err), 1u) << joined << "\n" << r.err;
    EXPECT_NE(r.err.find(c.flag), std::string::npos) << joined << "\n" << r.err;
    EXPECT_TRUE(r.out.empty()) << joined << "\n" << r.out;
  }
}

// `hapticctl status` and `stats` for a person (issue 23 item 5): the
// essentials in words with units, the full member dump under --verbose, the
// daemon's result unchanged under --json.
const char* const wall_device = R"(
[loop]
period = "1ms"
clock = "real"
overrun_limit = 0

[device]
driver = "loopback"
torque_limit = 20.0

[device.loopback]
motion = "linear"
mass = 0.1

[scene]
name = "wall"
stiffness = 9000.0
damping = 46.0
delay = 1
)";

bool has_line_starting(const std::string& text, const std::string& start) {
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(start, 0) == 0) return true;
  }
  return false;
}

TEST(CliStatus, HumanFormShowsTheEssentialsWithUnits) {
  TempDir dir;
  Daemon d(dir, wall_device);
  const CommandResult r = d.ctl({"status"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string& out = r.out;
  EXPECT_EQ(out.rfind("hapticd ", 0), 0u) << out;
  EXPECT_NE(out.find(": running"), std::string::npos) << out;
  EXPECT_NE(out.find("period 1 ms"), std::string::npos) << out;
  EXPECT_TRUE(has_line_starting(out, "  device:    loopback (linear), enabled")) << out;
  EXPECT_NE(out.find("torque limit 20 N"), std::string::npos) << out;
  // The scene with its parameters and their units.
  EXPECT_NE(out.find("wall: "), std::string::npos) << out;
  EXPECT_NE(out.find("stiffness 9000 N/m"), std::string::npos) << out;
  EXPECT_NE(out.find("damping 46 N s/m"), std::string::npos) << out;
  EXPECT_TRUE(has_line_starting(out, "  stability: stable")) << out;
  // Loop latency and overruns come from stats.
  EXPECT_NE(out.find("latency p50 "), std::string::npos) << out;
  EXPECT_NE(out.find("overruns "), std::string::npos) << out;
  EXPECT_TRUE(has_line_starting(out, "  recording: off")) << out;
  EXPECT_NE(out.find(" m, command "), std::string::npos) << out;
  // Not the member dump: no empty "problems:" nor growth_per_second.
  EXPECT_EQ(out.find("growth_per_second"), std::string::npos) << out;
  EXPECT_EQ(out.find("problems:"), std::string::npos) << out;
  EXPECT_LE(line_count(out), 24u) << "one screen:\n" << out;
}

TEST(CliStatus, FaultIsSaidFirstWithTheWayOut) {
  TempDir dir;
  Daemon d(dir, wall_device);
  ASSERT_EQ(d.ctl({"estop"}).exit_code, 0);
  const CommandResult r = d.ctl({"status"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  std::istringstream in(r.out);
  std::string first;
  std::string second;
  std::getline(in, first);
  std::getline(in, second);
  EXPECT_NE(first.find("FAULT (estop)"), std::string::npos) << r.out;
  EXPECT_EQ(second.rfind("  fault:", 0), 0u) << r.out;
  EXPECT_NE(second.find("hapticctl fault clear"), std::string::npos) << r.out;
}

TEST(CliStatus, JsonIsTheDaemonsResultAndVerboseEveryMember) {
  TempDir dir;
  Daemon d(dir, wall_device);
  const CommandResult r = d.ctl({"status", "--json"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const json status = json::parse(r.out);
  // The daemon's own result, member for member (a raw JSON-RPC call beside
  // it): nothing added, renamed or left out by the CLI.
  RawConnection raw(d.socket());
  ASSERT_TRUE(raw.send(R"({"jsonrpc":"2.0","id":1,"method":"status"})"
                       "\n"));
  const json direct = json::parse(raw.read_line())["result"];
  std::vector<std::string> keys;
  std::vector<std::string> direct_keys;
  for (const auto& [key, value] : status.items()) keys.push_back(key);
  for (const auto& [key, value] : direct.items()) direct_keys.push_back(key);
  EXPECT_EQ(keys, direct_keys) << r.out;
  EXPECT_EQ(status["scene"], direct["scene"]);
  EXPECT_EQ(status["device"], direct["device"]);
  EXPECT_EQ(status["scene"]["name"], "wall");
  EXPECT_FALSE(status.contains("latency"));
  const CommandResult verbose = d.ctl({"status", "--verbose"});
  ASSERT_EQ(verbose.exit_code, 0) << verbose.err;
  EXPECT_NE(verbose.out.find("growth_per_second:"), std::string::npos) << verbose.out;
  EXPECT_NE(verbose.out.find("effective_mass:"), std::string::npos) << verbose.out;
}

TEST(CliStats, HumanFormAndUnchangedJson) {
  TempDir dir;
  Daemon d(dir, wall_device);
  const CommandResult r = d.ctl({"stats"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(r.out.rfind("loop statistics since cycle 0: ", 0), 0u) << r.out;
  EXPECT_TRUE(has_line_starting(r.out, "  latency:   p50 ")) << r.out;
  EXPECT_NE(r.out.find(" us"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("p99.9 "), std::string::npos) << r.out;
  EXPECT_TRUE(has_line_starting(r.out, "  overruns:  ")) << r.out;
  EXPECT_TRUE(has_line_starting(r.out, "  device:    read errors 0")) << r.out;
  EXPECT_EQ(r.out.find("p999"), std::string::npos) << "member names are not shown:\n" << r.out;
  const CommandResult j = d.ctl({"stats", "--json"});
  ASSERT_EQ(j.exit_code, 0) << j.err;
  const json stats = json::parse(j.out);
  for (const char* key : {"since_cycle", "cycles", "overruns", "missed_periods", "latency", "compute",
                          "recorder", "control", "device"}) {
    EXPECT_TRUE(stats.contains(key)) << key << " in " << j.out;
  }
  EXPECT_TRUE(stats["latency"].contains("p50_us")) << j.out;
  const CommandResult verbose = d.ctl({"stats", "--verbose"});
  ASSERT_EQ(verbose.exit_code, 0) << verbose.err;
  EXPECT_NE(verbose.out.find("dropped_ring_total:"), std::string::npos) << verbose.out;
}

}  // namespace
}  // namespace hapticd::e2e::cli_test
