// No answer clipped by its box (identification/box_widening.h): a pressed bound widens
// by half the box's width, never past the grade's physical limit; identify() finds a truth
// outside the first box and records each widening; with the box fixed the same truth is clipped
// and flagged at_box_edge.
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "identification/box_widening.h"
#include "identification/grade.h"
#include "identification/identify_run.h"
#include "model/units.h"
#include "scenarios/noise.h"
#include "scenarios/scenario.h"

namespace insid {
namespace {

EstimatedParameter param(const std::string& name, double lo = -4.0, double hi = 4.0) {
  EstimatedParameter p = sensor_grade("mems").parameter(name);
  p.lower_sigma = lo;
  p.upper_sigma = hi;
  return p;
}

bool has_flag(const nlohmann::json& parameter, const std::string& flag) {
  for (const nlohmann::json& f : parameter.at("flags"))
    if (f == flag) return true;
  return false;
}

TEST(BoxWidening, APressedBoundMovesOutByHalfTheWidthAndOnlyThatOne) {
  const SensorGrade& mems = sensor_grade("mems");
  std::vector<EstimatedParameter> est = {param("gyro_bias_x"), param("gyro_bias_y"),
                                         param("accel_bias_x")};
  Eigen::VectorXd v(3);
  v << 3.97, 0.5, -4.0;  // within 1 % of the 8-sigma width of +4; inside; at -4
  const std::vector<BoxWidening> moved = widen_pressed_bounds(est, v, mems, {}, 1);
  ASSERT_EQ(moved.size(), 2u);
  EXPECT_EQ(moved[0].parameter, "gyro_bias_x");
  EXPECT_EQ(moved[0].side, "upper");
  EXPECT_DOUBLE_EQ(moved[0].to_sigma, 8.0);
  EXPECT_FALSE(moved[0].to_physical_limit);
  EXPECT_DOUBLE_EQ(est[0].lower_sigma, -4.0);  // the other side stays
  EXPECT_DOUBLE_EQ(est[1].upper_sigma, 4.0);   // not pressed: unchanged
  // accel x: 80 mg is 8 sigma of 10 mg, reached in one step: the limit, said so.
  EXPECT_EQ(moved[1].side, "lower");
  EXPECT_DOUBLE_EQ(moved[1].to_sigma, -8.0);
  EXPECT_TRUE(moved[1].to_physical_limit);
  // Pressed again at the limit: nothing moves, and the parameter is named as held there.
  v << 0.0, 0.0, -8.0;
  EXPECT_TRUE(widen_pressed_bounds(est, v, mems, {}, 2).empty());
  EXPECT_EQ(pressed_at_physical_limit(est, v, mems, {}), std::vector<std::string>{"accel_bias_x"});
  EXPECT_TRUE(beyond_physical_limit(est, v, mems).empty());
}

TEST(BoxWidening, NoBoundPassesThePhysicalLimit) {
  const SensorGrade& mems = sensor_grade("mems");
  // gyro bias: 20 deg/s = 200 sigma of 0.1 deg/s. Widening from [-4, 4] grows the box by half
  // its width a round: it reaches the limit and stops exactly there.
  std::vector<EstimatedParameter> est = {param("gyro_bias_z")};
  Eigen::VectorXd v(1);
  int rounds = 0;
  for (; rounds < 40; ++rounds) {
    v << est[0].upper_sigma;
    if (widen_pressed_bounds(est, v, mems, {}, rounds + 1).empty()) break;
    ASSERT_LE(est[0].upper_sigma * est[0].sigma, 20.0 * kDegToRad * (1 + 1e-12));
  }
  EXPECT_LT(rounds, 40);
  EXPECT_NEAR(est[0].upper_sigma * est[0].sigma, 20.0 * kDegToRad, 1e-12);
  // A user's box beyond the limit is not widened, and an estimate out there is flagged.
  std::vector<EstimatedParameter> user = {param("gyro_scale_x", -100.0, 100.0)};  // +-10 %
  v << 50.0;  // 5 %, above the datasheet's 3 %
  EXPECT_EQ(beyond_physical_limit(user, v, mems), std::vector<std::string>{"gyro_scale_x"});
  v << 100.0;
  EXPECT_TRUE(widen_pressed_bounds(user, v, mems, {}, 1).empty());
}

TEST(BoxWidening, OptionsNameTheBadValue) {
  BoxWideningOptions o;
  EXPECT_EQ(o.validate(), "");
  o.edge_fraction = 0.0;
  EXPECT_NE(o.validate().find("edge_fraction 0"), std::string::npos) << o.validate();
  o = {};
  o.max_rounds = 0;
  EXPECT_NE(o.validate().find("max_rounds 0"), std::string::npos) << o.validate();
  IdentifySpec spec;
  spec.data_dir = "x";
  spec.box_widening.growth_of_width = std::nan("");
  EXPECT_NE(spec.validate().find("growth_of_width"), std::string::npos) << spec.validate();
}

// A 250 s MEMS `rich` flight whose gyro x bias is 0.6 deg/s, 6 sigma: outside the first box.
std::shared_ptr<const Dataset> flight_with_large_gyro_bias() {
  scenarios::ScenarioConfig cfg = scenarios::preset_scenario("rich");
  cfg.align_s = 30.0;
  cfg.flight_s = 250.0;
  cfg.noise = scenarios::noise_grade("mems");
  cfg.seed = 3;
  cfg.injected = SensorErrors{};
  set_effect(cfg.injected, "gyro_bias_x", 0.6 * kDegToRad);
  set_effect(cfg.injected, "gyro_bias_y", -0.15 * kDegToRad);
  set_effect(cfg.injected, "accel_bias_x", 0.02 * kStandardGravity_mps2);
  return std::make_shared<const Dataset>(scenarios::simulate(cfg));
}

IdentifySpec spec_for(const std::shared_ptr<const Dataset>& data) {
  IdentifySpec s;
  s.dataset = data;
  s.algorithm = "lm";
  s.estimate = {"gyro_bias_x", "gyro_bias_y", "gyro_bias_z", "accel_bias_x", "accel_bias_y"};
  s.grade = "mems";
  s.iterations = 0;
  s.evaluations = 200;
  s.window_s = 10.0;
  s.initial_attitude.mode = InitialAttitudeMode::kLevelHeading;
  s.reference_optimum = false;
  s.uncertainty_replicas = 30;
  s.threads = 2;
  return s;
}

// GIVEN a truth outside the first box WHEN identify runs with the default widening THEN the
// upper bound of gyro_bias_x widens, the estimate lands within 3 sd of 0.6 deg/s, no estimate
// is flagged at_box_edge, and the result records the first box and each widening.
// WITH --fixed-box the same flight's gyro_bias_x stays at +4 sigma, flagged at_box_edge.
TEST(BoxWidening, IdentifyFindsATruthOutsideTheFirstBoxAndRecordsIt) {
  const auto data = flight_with_large_gyro_bias();
  const IdentifyReport wide = identify(spec_for(data));
  const nlohmann::json& bw = wide.result.at("box_widening");
  ASSERT_FALSE(bw.at("widenings").empty()) << bw.dump(2);
  bool x_upper = false;
  for (const nlohmann::json& w : bw.at("widenings"))
    x_upper |= w.at("parameter") == "gyro_bias_x" && w.at("side") == "upper";
  EXPECT_TRUE(x_upper) << bw.dump(2);
  EXPECT_EQ(bw.at("first_box_sigma").at("gyro_bias_x"), nlohmann::json({-4.0, 4.0}));
  EXPECT_EQ(bw.at("rounds").size(), bw.at("widenings").back().at("round").get<std::size_t>() + 1);
  EXPECT_TRUE(bw.at("at_physical_limit").empty());
  const nlohmann::json& gx = wide.result.at("parameters").at(0);
  ASSERT_EQ(gx.at("name"), "gyro_bias_x");
  const double truth = 0.6 * kDegToRad;
  const double sd = gx.at("sd").get<double>();
  std::cout << "widened: gyro_bias_x " << gx.at("estimate").get<double>() / kDegToRad << " +- "
            << sd / kDegToRad << " deg/s (truth 0.6)\n";
  EXPECT_LE(std::abs(gx.at("estimate").get<double>() - truth), 3.0 * sd);
  EXPECT_LT(sd, 0.1 * kDegToRad);  // a real answer, not a wide interval that covers anything
  for (const nlohmann::json& p : wide.result.at("parameters"))
    EXPECT_FALSE(has_flag(p, "at_box_edge")) << p.dump();
  // The estimated box recorded is the final one.
  EXPECT_GT(wide.result.at("estimated").at(0).at("upper_sigma").get<double>(), 4.0);

  IdentifySpec fixed = spec_for(data);
  fixed.box_widening.enabled = false;
  const IdentifyReport clipped = identify(fixed);
  const nlohmann::json& cx = clipped.result.at("parameters").at(0);
  EXPECT_NEAR(cx.at("estimate_in_sigma_units").get<double>(), 4.0, 1e-2);
  EXPECT_TRUE(has_flag(cx, "at_box_edge")) << cx.dump();
  EXPECT_TRUE(clipped.result.at("box_widening").at("widenings").empty());
  // The clipped fit pays elsewhere: its misfit is larger.
  EXPECT_GT(clipped.optimizer_result.best_f, wide.optimizer_result.best_f);
}

}  // namespace
}  // namespace insid
