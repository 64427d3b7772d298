// The cross-IMU check on simulated multi-IMU flights: one multicopter trajectory (the scenario
// config alone sets it), several IMUs with their own biases, scale factors and noise seeds. GIVEN
// the known truths WHEN the direct differences are measured THEN they recover the truths within
// their block SE, and the SE are honest over seeds; the comparison gives the right verdicts.
#include "diagnose/cross_imu.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>

#include "model/units.h"
#include "scenarios/scenario.h"
#include "test_support/enum_tables.h"

namespace insid::cross_imu {
namespace {

constexpr double kDeg = kDegToRad;  // deg/s -> rad/s

struct SimImu {
  Eigen::Vector3d gyro_bias_rad_s;
  Eigen::Vector3d gyro_scale = Eigen::Vector3d::Zero();
};

// One IMU of the shared multicopter flight: 5 s on the ground, `flight_s` of the preset's
// manoeuvres, MEMS white noise plus a Gauss-Markov gyro error with a 0.3 s correlation time
// (vibration-like: correlated from sample to sample, so the i.i.d. SE is too small).
Dataset simulate_imu(const SimImu& imu, std::uint64_t seed, double flight_s = 150.0) {
  scenarios::ScenarioConfig cfg = scenarios::preset_scenario("multicopter");
  cfg.align_s = 5.0;
  scenarios::ScenarioOverrides o;
  o.clean = true;
  o.seed = seed;
  o.flight_s = flight_s;
  const char* axis[3] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    o.set[std::string("gyro_bias_") + axis[i]] = imu.gyro_bias_rad_s(i);
    if (imu.gyro_scale(i) != 0.0) o.set[std::string("gyro_scale_") + axis[i]] = imu.gyro_scale(i);
  }
  cfg = scenarios::with_overrides(cfg, o);
  cfg.noise.gm_gyro_sigma_deg_h = 0.05 * 3600.0;  // 0.05 deg/s
  cfg.noise.gm_tau_s = 0.3;
  return scenarios::simulate(cfg);
}

// The intercept the model measures for a - b on axis i: db at zero *measured* mean rate. With
// omega_a = (1 + s_a) w + b_a, omega_b = (1 + s_b) w + b_b, the difference is db + (s_a - s_b) w,
// and w = (wbar - (b_a + b_b) / 2) / (1 + (s_a + s_b) / 2), so the intercept is
// db - K (b_a + b_b) / 2 with K = (s_a - s_b) / (1 + (s_a + s_b) / 2) (second order).
double expected_intercept(const SimImu& a, const SimImu& b, int i) {
  const double K =
      (a.gyro_scale(i) - b.gyro_scale(i)) / (1.0 + 0.5 * (a.gyro_scale(i) + b.gyro_scale(i)));
  return a.gyro_bias_rad_s(i) - b.gyro_bias_rad_s(i) -
         K * 0.5 * (a.gyro_bias_rad_s(i) + b.gyro_bias_rad_s(i));
}

const std::vector<SimImu>& three_imus() {
  static const std::vector<SimImu> imus = {
      {Eigen::Vector3d(0.10, -0.20, 0.05) * kDeg},
      // 2 % scale on z (the flight turns more one way than the other), 1 % on x.
      {Eigen::Vector3d(0.45, 0.10, -0.30) * kDeg, Eigen::Vector3d(0.01, 0.0, 0.02)},
      {Eigen::Vector3d(-0.20, 0.35, 0.25) * kDeg},
  };
  return imus;
}

std::vector<RateSeries> simulate_series(std::uint64_t seed0, std::vector<Dataset>* keep = nullptr) {
  std::vector<RateSeries> series;
  const char* names[3] = {"A", "B", "C"};
  for (std::size_t k = 0; k < three_imus().size(); ++k) {
    Dataset ds = simulate_imu(three_imus()[k], seed0 + k);
    series.push_back(rates_from_dataset(ds, names[k]));
    if (keep) keep->push_back(std::move(ds));
  }
  return series;
}

// The scenario config alone sets the trajectory: the seed and the injected errors do not.
TEST(CrossImu, SameConfigSameTrajectory) {
  std::vector<Dataset> ds;
  simulate_series(11, &ds);
  ASSERT_EQ(ds[0].truth.size(), ds[1].truth.size());
  ASSERT_FALSE(ds[0].truth.empty());
  for (std::size_t k = 0; k < ds[0].truth.size(); k += 97) {
    EXPECT_EQ(ds[0].truth[k].t_s, ds[1].truth[k].t_s);
    EXPECT_EQ(ds[0].truth[k].lat_rad, ds[2].truth[k].lat_rad);
    EXPECT_EQ(ds[0].truth[k].v_eb_n_mps, ds[1].truth[k].v_eb_n_mps);
  }
  ASSERT_EQ(ds[0].imu.size(), ds[1].imu.size());
  EXPECT_NE(ds[0].imu[100].dtheta_b_rad, ds[1].imu[100].dtheta_b_rad);  // their own noise
}

// GIVEN three IMUs with known different biases, one with scale-factor differences; WHEN the
// direct differences are measured over 8 noise seeds; THEN every independent pair-axis recovers
// its truth within 3.5 SE, at least 85 % within 2 SE, the SE are not inflated (rms z >= 0.5),
// and the scale differences come out as the K diagonal.
TEST(CrossImu, RecoversKnownDifferencesWithHonestSe) {
  int total = 0, within2 = 0;
  double sum_z2 = 0.0, sum_ratio = 0.0;
  double worst = 0.0;
  std::map<double, double> ladder_z2;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    const CrossImuReport r = direct_differences(simulate_series(100 * seed), CrossImuOptions{});
    ASSERT_EQ(r.pairs.size(), 3u);
    for (const PairDifference& p : r.pairs) {
      EXPECT_EQ(p.unmatched, 0u);
      EXPECT_TRUE(p.rate_column_used[0] && p.rate_column_used[1] && p.rate_column_used[2]);
      if (!p.against_first) continue;
      const SimImu& a = three_imus()[p.a];
      const SimImu& b = three_imus()[p.b];
      for (int i = 0; i < 3; ++i) {
        const AxisDifference& ax = p.axes[static_cast<std::size_t>(i)];
        ASSERT_TRUE(ax.se_rad_s.has_value());
        const double z = (ax.bias_diff_rad_s - expected_intercept(a, b, i)) / *ax.se_rad_s;
        ++total;
        within2 += std::abs(z) <= 2.0 ? 1 : 0;
        sum_z2 += z * z;
        sum_ratio += *ax.se_rad_s / ax.se_iid_rad_s;
        worst = std::max(worst, std::abs(z));
        for (const auto& [len, se] : ax.se_by_block)  // the SE's dependence on the block length
          if (se)
            ladder_z2[len] += std::pow((ax.bias_diff_rad_s - expected_intercept(a, b, i)) / *se, 2);
        EXPECT_LT(std::abs(z), 3.5) << p.name_a << "-" << p.name_b << " axis " << i << " seed "
                                    << seed << ": " << ax.bias_diff_rad_s / kDeg << " deg/s";
        // The scale difference on the diagonal, within 4 of its SE.
        const double K_true =
            (a.gyro_scale(i) - b.gyro_scale(i)) / (1.0 + 0.5 * (a.gyro_scale(i) + b.gyro_scale(i)));
        const auto& K = ax.rate_coeff[static_cast<std::size_t>(i)];
        const auto& K_se = ax.rate_coeff_se[static_cast<std::size_t>(i)];
        if (K && K_se)
          EXPECT_NEAR(*K, K_true, 4.0 * *K_se);
        else
          ADD_FAILURE() << "no rate coefficient on axis " << i;
      }
    }
  }
  const double rms_z = std::sqrt(sum_z2 / total);
  for (const auto& [len, z2] : ladder_z2)
    std::printf("SE from %g s blocks: rms z %.2f\n", len, std::sqrt(z2 / total));
  std::printf(
      "cross-imu simulated: %d pair-axes, %d within 2 SE, rms z %.2f, worst %.2f, "
      "block SE / iid SE %.2f\n",
      total, within2, rms_z, worst, sum_ratio / total);
  EXPECT_GE(within2, static_cast<int>(std::ceil(0.85 * total)));
  EXPECT_GE(rms_z, 0.5);  // SE not inflated
  EXPECT_LE(rms_z, 1.5);
  EXPECT_GT(sum_ratio / total, 1.5);  // the correlated noise: the i.i.d. SE would be too small
}

// Without the rate terms (a broken regression: every rate column dropped), the 2 % z scale
// difference times the flight's mean yaw rate lands in the bias difference: on the same data
// the error is many times the proper fit's SE, so the check above can fail.
TEST(CrossImu, DroppingTheRateTermsMissesTheScaleDifference) {
  const std::vector<RateSeries> series = simulate_series(100);
  const double truth = expected_intercept(three_imus()[1], three_imus()[0], 2);  // B - A, z
  const CrossImuReport good = direct_differences(series, CrossImuOptions{});
  CrossImuOptions broken_options;
  broken_options.min_rate_sd_rad_s = 1e3;  // no rate column enters
  const CrossImuReport broken = direct_differences(series, broken_options);
  ASSERT_EQ(good.pairs.front().name_a, "B");
  const AxisDifference& g = good.pairs.front().axes[2];
  const AxisDifference& b = broken.pairs.front().axes[2];
  std::printf("B-A z: with the rate terms %.4f +- %.4f deg/s, without %.4f +- %.4f, truth %.4f\n",
              g.bias_diff_rad_s / kDeg, *g.se_rad_s / kDeg, b.bias_diff_rad_s / kDeg,
              *b.se_rad_s / kDeg, truth / kDeg);
  EXPECT_LT(std::abs(g.bias_diff_rad_s - truth), 3.0 * *g.se_rad_s);
  EXPECT_GT(std::abs(b.bias_diff_rad_s - truth), 5.0 * *g.se_rad_s);
}

// A bias step in one IMU at t = 100 s shows in the segments: before it the segments hold the
// old difference, after it the new one.
TEST(CrossImu, SegmentsShowABiasStep) {
  std::vector<Dataset> ds;
  simulate_series(7, &ds);
  const double step = 0.6 * kDeg;
  for (std::size_t k = 1; k < ds[1].imu.size(); ++k)
    if (ds[1].imu[k].t_s > 100.0)
      ds[1].imu[k].dtheta_b_rad.x() += step * (ds[1].imu[k].t_s - ds[1].imu[k - 1].t_s);
  std::vector<RateSeries> series = {rates_from_dataset(ds[0], "A"), rates_from_dataset(ds[1], "B")};
  CrossImuOptions o;
  o.segment_s = 10.0;
  o.t_start_s = 10.0;
  const CrossImuReport r = direct_differences(series, o);
  ASSERT_EQ(r.pairs.size(), 1u);
  const double before = expected_intercept(three_imus()[1], three_imus()[0], 0);
  int checked = 0;
  for (const Segment& s : r.pairs[0].segments) {
    if (!s.se_rad_s[0] || (s.t_start_s < 100.0 && s.t_end_s > 100.0)) continue;
    const double truth = s.t_end_s <= 100.0 ? before : before + step;
    // K x rate removed with the window's K, which the step biases slightly: 4 SE + 0.03 deg/s.
    EXPECT_NEAR(s.bias_diff_rad_s.x(), truth, 4.0 * *s.se_rad_s[0] + 0.03 * kDeg)
        << s.t_start_s << "-" << s.t_end_s;
    ++checked;
  }
  EXPECT_GE(checked, 12);
}

// GIVEN three IMUs of one airframe whose gyro offsets step by known, different amounts when the
// motors start (a motor schedule from 17 s: 12 s of ground with the motors off after the 5 s
// static window, then the preset's flight) WHEN the direct differences are measured over
// 2-174 s with 1 s blocks THEN every pair-axis's jump at motor start equals the difference of the
// two motor offsets within 3.5 SE, and the pair's motors-off and -on samples are counted.
TEST(CrossImu, MotorJumpRecoversTheMotorOffsetDifference) {
  const Eigen::Vector3d offsets[3] = {Eigen::Vector3d(0.30, -0.10, 0.05) * kDeg,
                                      Eigen::Vector3d(-0.25, 0.20, 0.40) * kDeg,
                                      Eigen::Vector3d(0.05, 0.35, -0.20) * kDeg};
  std::vector<RateSeries> series;
  const char* names[3] = {"A", "B", "C"};
  for (int k = 0; k < 3; ++k) {
    scenarios::ScenarioConfig cfg = scenarios::preset_scenario("multicopter");
    cfg.align_s = 5.0;
    scenarios::ScenarioOverrides o;
    o.clean = true;
    o.seed = 40 + static_cast<std::uint64_t>(k);
    o.flight_s = 170.0;
    const char* axis[3] = {"x", "y", "z"};
    for (int i = 0; i < 3; ++i) {
      o.set[std::string("gyro_bias_") + axis[i]] = three_imus()[k].gyro_bias_rad_s(i);
      o.set[std::string("gyro_motor_offset_") + axis[i]] = offsets[k](i);
    }
    cfg = scenarios::with_overrides(cfg, o);
    cfg.segments.insert(cfg.segments.begin(),
                        nlohmann::json{{"type", "static"}, {"duration_s", 12.0}});
    cfg.motors.on_s = {{17.0, 175.0}};
    cfg.noise.gm_gyro_sigma_deg_h = 0.05 * 3600.0;
    cfg.noise.gm_tau_s = 0.3;
    series.push_back(rates_from_dataset(scenarios::simulate(cfg), names[k]));
    ASSERT_FALSE(series.back().motor_on.empty());
  }
  CrossImuOptions o;
  o.t_start_s = 2.0;
  o.t_end_s = 174.0;
  o.block_s = 1.0;
  const CrossImuReport r = direct_differences(series, o);
  ASSERT_EQ(r.pairs.size(), 3u);
  for (const PairDifference& p : r.pairs) {
    EXPECT_NEAR(static_cast<double>(p.motor_off_samples), 15.0 * 100.0, 1.0) << p.name_a;
    for (int i = 0; i < 3; ++i) {
      const AxisDifference& ax = p.axes[static_cast<std::size_t>(i)];
      ASSERT_TRUE(ax.motor_jump_rad_s && ax.motor_jump_se_rad_s) << p.name_a << " - " << p.name_b;
      const double truth = offsets[p.a](i) - offsets[p.b](i);
      std::cout << p.name_a << " - " << p.name_b << " axis " << i << ": jump "
                << *ax.motor_jump_rad_s / kDeg << " +- " << *ax.motor_jump_se_rad_s / kDeg
                << " deg/s, truth " << truth / kDeg << "\n";
      EXPECT_NEAR(*ax.motor_jump_rad_s, truth, 3.5 * *ax.motor_jump_se_rad_s)
          << p.name_a << " - " << p.name_b << " axis " << i;
    }
  }
}

TEST(CrossImu, OptionsAndInputsRefusedWithReasons) {
  CrossImuOptions o;
  o.block_s = 0.0;
  EXPECT_NE(o.validate().find("--block-s 0"), std::string::npos) << o.validate();
  o = {};
  o.t_start_s = 50.0;
  o.t_end_s = 10.0;
  EXPECT_NE(o.validate().find("--t-start 50 must be before --t-end 10"), std::string::npos);
  o = {};
  o.segment_s = std::nan("");
  EXPECT_NE(o.validate().find("--segment-s"), std::string::npos);

  std::vector<RateSeries> series = simulate_series(3);
  EXPECT_THROW(direct_differences({series[0]}, {}), std::invalid_argument);
  // An IMU logged at other instants (shifted by half a step): no matched samples, said so.
  RateSeries shifted = series[1];
  for (double& t : shifted.t_s) t += 0.005;
  try {
    direct_differences({series[0], shifted}, {});
    ADD_FAILURE() << "shifted instants accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("same instants"), std::string::npos) << e.what();
  }
  o = {};
  o.t_start_s = 1e6;
  EXPECT_THROW(direct_differences(series, o), std::invalid_argument);
  o = {};
  o.segment_s = 1e-4;  // 1.5 million segments over the flight
  try {
    direct_differences(series, o);
    ADD_FAILURE() << "a million segments accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("--segment-s 0.0001"), std::string::npos) << e.what();
  }
}

// Fabricated results around a known direct difference give the right verdicts.
TEST(CrossImu, ComparisonVerdicts) {
  CrossImuReport report;
  report.names = {"IMU", "IMU2"};
  report.options = {};
  PairDifference p;
  p.a = 1;
  p.b = 0;
  p.name_a = "IMU2";
  p.name_b = "IMU";
  p.against_first = true;
  for (int i = 0; i < 3; ++i) {
    p.axes[static_cast<std::size_t>(i)].bias_diff_rad_s = 0.2 * kDeg;
    p.axes[static_cast<std::size_t>(i)].se_rad_s = 0.03 * kDeg;
  }
  report.pairs.push_back(p);
  // sd_a = sd_b = 0.02 deg/s: combined sqrt(0.02^2 + 0.02^2 + 0.03^2) = 0.0412 deg/s.
  auto result = [](double x, double y, double z, std::vector<std::string> flags_x = {}) {
    ResultEstimates r;
    const double v[3] = {x, y, z};
    for (int i = 0; i < 3; ++i) {
      EstimatedBias e;
      e.estimate_rad_s = v[i] * kDeg;
      e.sd_rad_s = 0.02 * kDeg;
      if (i == 0) e.flags = flags_x;
      r.gyro_bias[static_cast<std::size_t>(i)] = e;
    }
    return r;
  };
  const ResultEstimates base = result(0.0, 0.0, 0.0);
  // x: 0.21 (z 0.24, agree); y: 0.30 (z 2.43, check); z: 0.84 (z 15.5, disagree).
  const ResultEstimates r2 = result(0.21, 0.30, 0.84, {"at_box_edge"});
  const std::vector<ComparisonRow> rows = compare_with_results(report, {base, r2});
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].verdict, Verdict::kAgree);
  EXPECT_EQ(rows[1].verdict, Verdict::kCheck);
  EXPECT_EQ(rows[2].verdict, Verdict::kDisagree);
  EXPECT_NEAR(*rows[0].z, 0.01 / std::sqrt(0.02 * 0.02 * 2 + 0.03 * 0.03), 1e-9);
  EXPECT_EQ(rows[0].flags, std::vector<std::string>{"IMU2 at_box_edge"});
  const std::vector<std::string> w = comparison_warnings(report, rows);
  ASSERT_EQ(w.size(), 2u);
  EXPECT_NE(w[0].find("insid's gyro_bias_z for IMU2 disagrees with its own airframe"),
            std::string::npos)
      << w[0];
  EXPECT_NE(w[1].find("gyro_bias_x of IMU2 is at its box edge"), std::string::npos) << w[1];
  // No sd: not compared, and said why; a missing estimate likewise.
  ResultEstimates no_sd = r2;
  no_sd.gyro_bias[1]->sd_rad_s.reset();
  no_sd.gyro_bias[2].reset();
  const std::vector<ComparisonRow> rows2 = compare_with_results(report, {base, no_sd});
  EXPECT_EQ(rows2[1].verdict, Verdict::kNotCompared);
  EXPECT_NE(rows2[1].reason.find("gives no sd"), std::string::npos);
  EXPECT_EQ(rows2[2].verdict, Verdict::kNotCompared);
  EXPECT_NE(rows2[2].reason.find("not estimated"), std::string::npos);
  EXPECT_THROW(compare_with_results(report, {base}), std::invalid_argument);
  EXPECT_EQ(verdict_from_z(-3.01), Verdict::kDisagree);
  EXPECT_EQ(verdict_from_z(2.0), Verdict::kAgree);
  const nlohmann::json j = report_json(report, &rows);
  EXPECT_EQ(j.at("comparison").at(2).at("verdict"), "disagree");
  EXPECT_EQ(j.at("comparison_independent_counts").at("agree"), 1);
  // An sd larger than any difference the airframe shows (0.2 deg/s here) tells nothing: not
  // compared, whatever its z would be (0.84 +- 0.3: z 2.1), and said why.
  ResultEstimates wide = r2;
  wide.gyro_bias[2]->sd_rad_s = 0.3 * kDeg;
  const std::vector<ComparisonRow> rows3 = compare_with_results(report, {base, wide});
  EXPECT_EQ(rows3[0].verdict, Verdict::kAgree);
  EXPECT_EQ(rows3[2].verdict, Verdict::kNotCompared);
  EXPECT_NE(rows3[2].reason.find("cannot tell these IMUs apart"), std::string::npos)
      << rows3[2].reason;
  // Motor offsets are compared with the jump at motor start where the pair has one.
  report.pairs[0].axes[0].motor_jump_rad_s = 0.5 * kDeg;
  report.pairs[0].axes[0].motor_jump_se_rad_s = 0.04 * kDeg;
  ResultEstimates motor = r2;
  EstimatedBias offset;
  offset.estimate_rad_s = 0.45 * kDeg;
  offset.sd_rad_s = 0.03 * kDeg;
  motor.gyro_motor_offset[0] = offset;
  const std::vector<ComparisonRow> rows4 = compare_with_results(report, {base, motor});
  ASSERT_EQ(rows4.size(), 4u);
  EXPECT_EQ(rows4[3].kind, EffectKind::kMotorOffset);
  EXPECT_EQ(rows4[3].reason, "gyro_motor_offset_x not estimated in the result of IMU");
  ResultEstimates base_motor = base;
  offset.estimate_rad_s = 0.0;
  base_motor.gyro_motor_offset[0] = offset;
  const std::vector<ComparisonRow> rows5 = compare_with_results(report, {base_motor, motor});
  ASSERT_EQ(rows5.size(), 4u);
  EXPECT_NEAR(*rows5[3].z, (0.45 - 0.5) / std::sqrt(0.03 * 0.03 * 2 + 0.04 * 0.04), 1e-9);
  EXPECT_EQ(report_json(report, &rows5).at("comparison").at(3).at("parameter"),
            "gyro_motor_offset_x");
}

// An insid-identify/2 file is read by name; another format is refused naming the field.
TEST(CrossImu, ReadsIdentifyResults) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path();
  const std::filesystem::path good =
      dir / ("insid_cross_imu_test_" + std::to_string(::getpid()) + ".json");
  std::ofstream(good)
      << R"({"format": "insid-identify/2", "algorithm": {"name": "EKF-RTS"}, "parameters": [
    {"name": "gyro_bias_x", "estimate": 0.0069813, "sd": 8.5e-05, "unit": "rad/s",
     "flags": ["at_box_edge"]},
    {"name": "gyro_bias_z", "estimate": -0.001, "sd": null, "unit": "rad/s", "flags": []},
    {"name": "accel_bias_z", "estimate": 0.39, "sd": 0.0019, "unit": "m/s^2", "flags": []}]})";
  const ResultEstimates r = read_identify_result(good);
  EXPECT_EQ(r.algorithm, "EKF-RTS");
  ASSERT_TRUE(r.gyro_bias[0].has_value());
  EXPECT_DOUBLE_EQ(r.gyro_bias[0]->estimate_rad_s, 0.0069813);
  EXPECT_EQ(r.gyro_bias[0]->flags, std::vector<std::string>{"at_box_edge"});
  EXPECT_FALSE(r.gyro_bias[1].has_value());
  ASSERT_TRUE(r.gyro_bias[2].has_value());
  EXPECT_FALSE(r.gyro_bias[2]->sd_rad_s.has_value());
  std::ofstream(good) << R"({"format": "insid-navigate/1", "parameters": []})";
  try {
    read_identify_result(good);
    ADD_FAILURE() << "a navigate summary read as a result";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("format: expected \"insid-identify/2\""),
              std::string::npos)
        << e.what();
  }
  std::filesystem::remove(good);
}

TEST(CrossImu, VerdictNamesRoundTrip) {
  test::expect_enum_table(kVerdictNames, {{Verdict::kAgree, "agree"},
                                          {Verdict::kCheck, "check"},
                                          {Verdict::kDisagree, "disagree"},
                                          {Verdict::kNotCompared, "not_compared"}});
  EXPECT_STREQ(to_string(Verdict::kNotCompared), "not_compared");
}

}  // namespace
}  // namespace insid::cross_imu
