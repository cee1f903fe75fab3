// world/text.hpp: the one number formatter and join. Each format is checked
// against what the code it replaced printed (iostream's default, printf's
// %.Ng and %.Nf, std::to_chars' shortest text), so messages, notes and
// recordings keep their look.

#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "world/text.hpp"

namespace hapticd::world::text::text_test {
namespace {

const std::vector<double>& samples() {
  static const std::vector<double> values{0.0,    -0.0,       0.1,    1.0 / 3.0, 250e-6 * 1e6, 1e-9,
                                          1e6,    1.5e9,      -1e300, 1e308,     9000.0,       46.0,
                                          0.5e-3, 123456.789, 1.0186, -2.5,      78.956835,    1e15};
  return values;
}

std::string printf_text(const char* format, double value) {
  char buffer[512];
  std::snprintf(buffer, sizeof buffer, format, value);
  return buffer;
}

TEST(Text, FormatSignificantIsPrintfG) {
  for (const double x : samples()) {
    EXPECT_EQ(format_significant(x, 3), printf_text("%.3g", x)) << x;
    EXPECT_EQ(format_significant(x, 4), printf_text("%.4g", x)) << x;
    EXPECT_EQ(format_significant(x, 10), printf_text("%.10g", x)) << x;
    EXPECT_EQ(format_significant(x, 17), printf_text("%.17g", x)) << x;
  }
}

TEST(Text, MessagePrecisionIsTheIostreamDefault) {
  for (const double x : samples()) {
    std::ostringstream out;
    out << x;
    EXPECT_EQ(format_significant(x, precision::message), out.str()) << x;
  }
  EXPECT_EQ(format_significant(1e9, precision::message), "1e+09");
  EXPECT_EQ(format_significant(1e-9, precision::message), "1e-09");
}

TEST(Text, FormatNumberIsTheShortestRoundTrip) {
  EXPECT_EQ(format_number(0.1), "0.1");
  EXPECT_EQ(format_number(250.0), "250");
  EXPECT_EQ(format_number(1e6), "1e+06");
  EXPECT_EQ(format_number(1e-300), "1e-300");
  EXPECT_EQ(format_number(0.1 + 0.2), "0.30000000000000004");
  for (const double x : samples()) EXPECT_EQ(std::stod(format_number(x)), x) << x;
  std::string line = "x=";
  append_number(line, 0.25);
  EXPECT_EQ(line, "x=0.25");
}

TEST(Text, FormatFixedIsPrintfF) {
  for (const double x : samples()) {
    EXPECT_EQ(format_fixed(x, 9), printf_text("%.9f", x)) << x;
    EXPECT_EQ(format_fixed(x, 0), printf_text("%.0f", x)) << x;
  }
  EXPECT_EQ(format_fixed(0.999998026, 9), "0.999998026");
}

TEST(Text, NonFiniteValuesAreWords) {
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(format_number(inf), "inf");
  EXPECT_EQ(format_number(-inf), "-inf");
  EXPECT_EQ(format_significant(std::numeric_limits<double>::quiet_NaN(), 6), "nan");
  EXPECT_EQ(format_fixed(-inf, 2), "-inf");
}

TEST(Text, QuantityAndJoin) {
  EXPECT_EQ(format_quantity(0.0010186, "N m s/rad"), "0.0010186 N m s/rad");
  EXPECT_EQ(format_quantity(46.0, "N s/m", precision::summary), "46 N s/m");
  EXPECT_EQ(format_quantity(2.0, ""), "2");
  EXPECT_EQ(join({"a", "b", "c"}), "a, b, c");
  EXPECT_EQ(join(std::vector<std::string>{"x", "y"}, " | "), "x | y");
  EXPECT_EQ(join(std::vector<std::string>{}), "");
}

}  // namespace
}  // namespace hapticd::world::text::text_test
