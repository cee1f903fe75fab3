// The one rule behind every verdict (analysis/verdict.hpp): a spectral
// radius becomes stable/marginal/unstable only from finite numbers precise
// enough to decide it; otherwise cannot_assess, with the reason.
#include "analysis/verdict.hpp"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace hapticd::analysis::verdict_test {
namespace {

constexpr double nan = std::numeric_limits<double>::quiet_NaN();
constexpr double inf = std::numeric_limits<double>::infinity();

TEST(Verdict, FiniteRadiiAreJudgedAgainstTheUnitCircle) {
  const NumericRecord clean;
  EXPECT_EQ(judge_radius(0.5, 1e-12, 1e-3, clean).state, VerdictState::stable);
  EXPECT_EQ(judge_radius(1.5, 1e-12, 1e-3, clean).state, VerdictState::unstable);
  EXPECT_EQ(judge_radius(1.0 + 1e-13, 1e-12, 1e-3, clean).state, VerdictState::marginal);
  EXPECT_EQ(judge_radius(1.0 - 1e-8, 1e-7, 1e-3, clean).state, VerdictState::marginal);
  EXPECT_TRUE(judge_radius(1.0 + 1e-13, 1e-12, 1e-3, clean).stable());  // marginal does not grow
  EXPECT_TRUE(judge_radius(0.5, 1e-12, 1e-3, clean).reason.empty());
  // A free drift root at 1 + 0 is marginal even with tolerance 0.
  EXPECT_EQ(judge_radius(1.0, 0.0, 1e-3, clean).state, VerdictState::marginal);
}

// Before this rule a NaN radius compared false everywhere: "radius <= 1 +
// tol" was false but max() over NaN poles returned 0, and the gate read 0 as
// stable (spring-wheel damping=1e308: "stable, pole radius 0.000000000").
TEST(Verdict, NonFiniteRadiusOrRecordCannotBeAssessed) {
  const NumericRecord clean;
  for (const double r : {nan, inf, -inf}) {
    const Verdict v = judge_radius(r, 1e-12, 1e-3, clean);
    EXPECT_EQ(v.state, VerdictState::cannot_assess) << r;
    EXPECT_FALSE(v.stable()) << r;
    EXPECT_FALSE(v.reason.empty()) << r;
  }
  NumericRecord dirty;
  dirty.check_finite("b / J", inf);
  dirty.check_finite("k / J", nan);  // the first problem is the reason
  const Verdict v = judge_radius(0.5, 1e-12, 1e-3, dirty);
  EXPECT_EQ(v.state, VerdictState::cannot_assess);
  EXPECT_EQ(v.reason, "b / J overflowed to inf");
  EXPECT_FALSE(v.stable());
  EXPECT_EQ(judge_radius(0.5, nan, 1e-3, clean).state, VerdictState::cannot_assess);
}

// A radius within a coarse rounding of 1 says nothing: it might grow.
TEST(Verdict, RadiusKnownTooCoarselyCannotBeAssessed) {
  const NumericRecord clean;
  const Verdict coarse = judge_radius(0.9999, 1e-3, 1e-3, clean, "w_n T = 7e10");
  EXPECT_EQ(coarse.state, VerdictState::cannot_assess);
  EXPECT_NE(coarse.reason.find("w_n T = 7e10"), std::string::npos) << coarse.reason;
  EXPECT_NE(coarse.reason.find("+-0.001"), std::string::npos) << coarse.reason;
  // At 1 us a band of 1e-7 could hide x1.1 per second: too coarse as well.
  EXPECT_EQ(judge_radius(1.0, max_radius_tolerance, 1e-6, clean).state, VerdictState::cannot_assess);
  EXPECT_EQ(judge_radius(1.0, max_radius_tolerance, 1e-3, clean).state, VerdictState::marginal);
  // Far outside the band the coarse radius still decides.
  EXPECT_EQ(judge_radius(10.0, 1e-3, 1e-3, clean).state, VerdictState::unstable);
}

TEST(Verdict, SpectrumRecordsNonFiniteEntriesAndDoesNotRunOnThem) {
  NumericRecord record;
  Eigen::MatrixXd a = Eigen::MatrixXd::Identity(2, 2);
  a(1, 1) = -inf;
  const Spectrum s = spectrum("Ad", a, record);
  EXPECT_TRUE(std::isnan(s.radius));
  EXPECT_TRUE(s.eigenvalues.empty());
  EXPECT_EQ(record.reason(), "an entry of Ad overflowed to inf");
  NumericRecord nan_record;
  a(1, 1) = nan;
  spectrum("Ad", a, nan_record);
  EXPECT_EQ(nan_record.reason(), "an entry of Ad is NaN");
  NumericRecord fine;
  EXPECT_NEAR(spectrum("Ad", Eigen::MatrixXd::Identity(3, 3) * 0.5, fine).radius, 0.5, 1e-15);
  EXPECT_TRUE(fine.clean());
  EXPECT_EQ(spectrum("empty", Eigen::MatrixXd(0, 0), fine).radius, 0.0);
}

TEST(Verdict, WorseOrdersCannotAssessThenUnstableThenMarginal) {
  const Verdict stable{VerdictState::stable, {}};
  const Verdict marginal{VerdictState::marginal, {}};
  const Verdict unstable{VerdictState::unstable, {}};
  const Verdict unknown{VerdictState::cannot_assess, "why"};
  EXPECT_EQ(worse(stable, marginal).state, VerdictState::marginal);
  EXPECT_EQ(worse(unstable, marginal).state, VerdictState::unstable);
  EXPECT_EQ(worse(unstable, unknown).reason, "why");
  EXPECT_EQ(worse(unknown, stable).reason, "why");
  EXPECT_EQ(to_string(VerdictState::cannot_assess), "cannot_assess");
  EXPECT_FALSE(Verdict{}.stable());  // a default verdict is not a verdict
}

}  // namespace
}  // namespace hapticd::analysis::verdict_test
