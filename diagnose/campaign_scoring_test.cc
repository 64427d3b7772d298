// The campaign's per-case scoring (diagnose/campaign_scoring.h) on hand-made rows shaped like
// cases.jsonl's `hidden_rows[truth]` and `first_candidates`.
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "diagnose/campaign_scoring.h"

namespace insid::diagnose {
namespace {

using json = nlohmann::json;

// A first-iteration candidate row: sd 0.02 SI = 0.2 sigma (sigma 0.1 SI), minimum detectable
// 1 sigma = 0.1 SI alone; `partners` its collinear list (effect, correlation).
json row(const std::string& effect, std::vector<std::pair<std::string, double>> partners,
         bool observable = true) {
  json r = {{"effect", effect},         {"sd", 0.02},
            {"sd_sigma", 0.2},          {"min_detectable_sigma", 1.0},
            {"observable", observable}, {"collinear", json::array()}};
  for (const auto& [n, c] : partners)
    r["collinear"].push_back({{"effect", n}, {"correlation", c}, {"separating_manoeuvre", "-"}});
  return r;
}

TEST(CaseLimits, AStronglyCorrelatedPartnerMakesADetectableCaseNotSeparable) {
  // Injected 0.3 = 3x the size detectable alone. A partner at rho 0.98 inflates the joint sd by
  // 1 / sqrt(1 - 0.98^2) = 5.03: the joint minimum detectable size 0.50 exceeds the injected.
  const CaseLimits c = case_limits(row("accel_scale_z", {{"accel_bias_z", 0.98}}), 0.3);
  EXPECT_TRUE(c.has_row);
  EXPECT_NEAR(c.min_detectable, 0.1, 1e-12);
  EXPECT_TRUE(c.detectable);
  EXPECT_EQ(c.partner, "accel_bias_z");
  EXPECT_NEAR(c.inflation, 1.0 / std::sqrt(1.0 - 0.98 * 0.98), 1e-12);
  EXPECT_NEAR(c.min_separable, 0.1 / std::sqrt(1.0 - 0.98 * 0.98), 1e-12);
  EXPECT_FALSE(c.separable);
  // The same partner does not stop a size above the joint limit (0.6 > 0.503).
  EXPECT_TRUE(case_limits(row("accel_scale_z", {{"accel_bias_z", 0.98}}), -0.6).separable);
}

TEST(CaseLimits, AWeaklyCorrelatedPartnerLeavesItSeparable) {
  // rho 0.3: inflation 1.048, joint limit 0.105 < 0.3.
  const CaseLimits c = case_limits(row("lever_arm_x", {{"gnss_latency", 0.3}}), 0.3);
  EXPECT_TRUE(c.detectable);
  EXPECT_NEAR(c.inflation, 1.0 / std::sqrt(1.0 - 0.09), 1e-12);
  EXPECT_TRUE(c.separable);
  // Without partners: separable exactly when detectable.
  const CaseLimits alone = case_limits(row("lever_arm_x", {}), 0.3);
  EXPECT_EQ(alone.partner, "");
  EXPECT_EQ(alone.inflation, 1.0);
  EXPECT_TRUE(alone.separable);
  EXPECT_FALSE(case_limits(row("lever_arm_x", {}), 0.05).detectable);
  EXPECT_FALSE(case_limits(row("lever_arm_x", {}), 0.05).separable);
}

TEST(CaseLimits, TheMostCorrelatedPartnerOfEitherSignDecides) {
  const CaseLimits c = case_limits(
      row("gyro_misalign_xy", {{"gyro_scale_z", 0.96}, {"gyro_misalign_yx", -0.99}}), 0.3);
  EXPECT_EQ(c.partner, "gyro_misalign_yx");
  EXPECT_NEAR(c.partner_correlation, 0.99, 1e-12);
  EXPECT_NEAR(c.inflation, 1.0 / std::sqrt(1.0 - 0.99 * 0.99), 1e-12);
  EXPECT_FALSE(c.separable);
  // |rho| = 1: no finite size separates them.
  const CaseLimits one = case_limits(row("a", {{"b", 1.0}}), 1e9);
  EXPECT_TRUE(std::isinf(one.min_separable));
  EXPECT_FALSE(one.separable);
}

TEST(CaseLimits, NotObservableOrNoRow) {
  const CaseLimits c = case_limits(row("accel_scale_y", {}, false), 10.0);
  EXPECT_FALSE(c.detectable);
  EXPECT_FALSE(c.separable);
  // A campaign without a limits row for the case: counted detectable.
  const CaseLimits none = case_limits(json(), 1.0);
  EXPECT_FALSE(none.has_row);
  EXPECT_TRUE(none.detectable);
}

TEST(ClassInflation, TheWholeRecordedClassAgainstTheOnePartnerBound) {
  // Truth t, partners p and q: R = [[1, a, b], [a, 1, c], [b, c, 1]];
  // (R^-1)_00 = (1 - c^2) / det R.
  const double a = 0.96, b = 0.97, c = 0.99;
  const json table = {row("t", {{"p", a}, {"q", b}}), row("p", {{"t", a}, {"q", c}}),
                      row("q", {{"t", b}, {"p", c}}), row("other", {})};
  const double det = 1.0 + 2.0 * a * b * c - a * a - b * b - c * c;
  const double expected = std::sqrt((1.0 - c * c) / det);
  EXPECT_NEAR(class_inflation(table, "t"), expected, 1e-9 * expected);
  // The one-partner inflation is a lower bound of it.
  EXPECT_LE(case_limits(table[0], 1.0).inflation, class_inflation(table, "t"));
  EXPECT_EQ(class_inflation(table, "other"), 1.0);
  // A mutual correlation not recorded (p and q below the threshold): unknown.
  const json partial = {row("t", {{"p", a}, {"q", b}}), row("p", {{"t", a}}), row("q", {{"t", b}})};
  EXPECT_TRUE(std::isnan(class_inflation(partial, "t")));
  EXPECT_TRUE(std::isnan(class_inflation(table, "absent")));
}

TEST(FirstName, TheFourAnswers) {
  auto f = [](const std::string& e, std::vector<std::string> amb) {
    return json{{"effect", e}, {"ambiguous_with", amb}};
  };
  EXPECT_EQ(first_name(json::array(), "a"), FirstName::kNothing);
  EXPECT_EQ(first_name(json::array({f("a", {"b"})}), "a"), FirstName::kTruth);
  EXPECT_EQ(first_name(json::array({f("b", {"a"}), f("a", {})}), "a"),
            FirstName::kTruthInFlaggedSet);
  EXPECT_EQ(first_name(json::array({f("b", {"c"})}), "a"), FirstName::kWrongFlagged);
  EXPECT_EQ(first_name(json::array({f("b", {}), f("a", {})}), "a"), FirstName::kWrongUnflagged);
}

}  // namespace
}  // namespace insid::diagnose
