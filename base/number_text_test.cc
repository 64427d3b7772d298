#include "base/number_text.h"

#include <cmath>
#include <iomanip>
#include <limits>
#include <random>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

namespace insid {
namespace {

// What the helpers number_text replaced wrote: an ostream with that precision.
std::string ostream_text(double value, int digits, bool fixed) {
  std::ostringstream s;
  if (fixed) s << std::fixed;
  s << std::setprecision(digits) << value;
  return s.str();
}

TEST(NumberText, SignificantDigitsDropTrailingZerosAndUseExponents) {
  EXPECT_EQ(number_text(0.1234, 3), "0.123");
  EXPECT_EQ(number_text(2.5, 12), "2.5");
  EXPECT_EQ(number_text(1.0e-7, 3), "1e-07");
  EXPECT_EQ(number_text(123456.0, 3), "1.23e+05");
  EXPECT_EQ(number_text(-0.5, 6), "-0.5");
  EXPECT_EQ(number_text(0.1, 17), "0.10000000000000001");
}

TEST(NumberText, DigitsAfterPointKeepThemAll) {
  EXPECT_EQ(number_text(2.5, 2, Digits::kAfterPoint), "2.50");
  EXPECT_EQ(number_text(12.0, 6, Digits::kAfterPoint), "12.000000");
  EXPECT_EQ(number_text(-1.25, 0, Digits::kAfterPoint), "-1");
  // Longer than any fixed buffer: all digits of 1e300.
  EXPECT_EQ(number_text(1.0e300, 1, Digits::kAfterPoint), ostream_text(1.0e300, 1, true));
  EXPECT_EQ(number_text(1.0e300, 1, Digits::kAfterPoint).size(), 303u);
}

TEST(NumberText, NonFiniteValues) {
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(number_text(inf, 6), "inf");
  EXPECT_EQ(number_text(-inf, 6), "-inf");
  EXPECT_EQ(number_text(std::nan(""), 6), "nan");
  EXPECT_EQ(number_text(inf), "inf");
}

TEST(NumberText, SameTextAsAnOstreamWithThatPrecision) {
  // GIVEN values over many magnitudes (fixed seed) WHEN printed with every precision the
  // replaced helpers used THEN number_text writes what their ostreams wrote.
  std::mt19937 rng(35);
  std::uniform_real_distribution<double> mantissa(-10.0, 10.0);
  std::uniform_int_distribution<int> exponent(-12, 12);
  for (int k = 0; k < 2000; ++k) {
    const double v = mantissa(rng) * std::pow(10.0, exponent(rng));
    for (const int digits : {0, 1, 2, 3, 4, 6, 10, 12, 17}) {
      ASSERT_EQ(number_text(v, digits), ostream_text(v, digits, false)) << v << " " << digits;
      ASSERT_EQ(number_text(v, digits, Digits::kAfterPoint), ostream_text(v, digits, true))
          << v << " " << digits;
    }
  }
}

TEST(NumberText, ShortestTextReadsBackToTheSameDouble) {
  EXPECT_EQ(number_text(0.05), "0.05");
  EXPECT_EQ(number_text(1.7), "1.7");
  EXPECT_EQ(number_text(1.0e-7), "1e-07");
  std::mt19937 rng(37);
  std::uniform_real_distribution<double> any(-1.0e6, 1.0e6);
  for (int k = 0; k < 2000; ++k) {
    const double v = any(rng);
    ASSERT_EQ(std::stod(number_text(v)), v) << number_text(v);
  }
}

}  // namespace
}  // namespace insid
