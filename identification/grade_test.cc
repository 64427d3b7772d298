// `--grade auto` reads the data: the meta.json noise block when there is one,
// else the static window's measured noise and gyro bias; nav only as a stated assumption.
#include "identification/grade.h"

#include <cmath>
#include <iterator>
#include <stdexcept>
#include <string>

#include <gtest/gtest.h>

#include "data/grade_table.h"
#include "identification/window_study.h"
#include "model/units.h"
#include "scenarios/noise.h"
#include "scenarios/scenario.h"

namespace insid {
namespace {

// A simulated flight that looks measured: no injected answer, no noise block in meta.json.
Dataset measured_looking(const std::string& grade, double flight_s = 20.0) {
  scenarios::ScenarioOverrides o;
  o.grade = grade;
  o.flight_s = flight_s;
  o.seed = 3;
  return scenarios::simulate_preset("straight", o, /*record_truth_in_meta=*/false);
}

TEST(GradeChoice, AutoMeasuresTheStaticWindowWhenMetaJsonDeclaresNoNoise) {
  const Dataset nav = measured_looking("nav");
  ASSERT_FALSE(nav.meta.noise.has_value());
  const GradeChoice n = choose_grade(nav);
  EXPECT_EQ(n.grade, "nav") << n.rule;
  EXPECT_EQ(n.source, "static window");
  // The simulator's nav noise (scenarios/noise.cc): ARW 0.002 deg/sqrt(h), VRW 0.001 m/s/sqrt(h).
  EXPECT_NEAR(n.arw_deg_rth, 0.002, 0.0006) << n.rule;
  EXPECT_NEAR(n.vrw_mps_rth, 0.001, 0.0003) << n.rule;
  EXPECT_EQ(default_window_s(n), 0.0);

  const Dataset mems = measured_looking("mems");
  const GradeChoice m = choose_grade(mems);
  EXPECT_EQ(m.grade, "mems") << m.rule;
  EXPECT_EQ(m.source, "static window");
  EXPECT_NEAR(m.arw_deg_rth, 0.2, 0.06) << m.rule;  // mems: 0.2 deg/sqrt(h), 0.05 m/s/sqrt(h)
  EXPECT_NEAR(m.vrw_mps_rth, 0.05, 0.015) << m.rule;
  EXPECT_EQ(default_window_s(m), 10.0);
  // The rule and its numbers are in the record and the line.
  EXPECT_NE(m.rule.find("ARW"), std::string::npos);
  EXPECT_EQ(m.to_json().at("source"), "static window");
  EXPECT_NEAR(m.to_json().at("arw_deg_rth").get<double>(), m.arw_deg_rth, 1e-12);
}

TEST(GradeChoice, AGyroBiasFarAboveEarthRateIsMemsWhateverTheNoise) {
  // A quiet gyro (nav-grade noise) with a 0.2 deg/s bias is no navigation-grade unit.
  Dataset d = measured_looking("nav");
  const double bias_rad_s = 0.2 * M_PI / 180.0;
  for (std::size_t k = 1; k < d.imu.size(); ++k)
    d.imu[k].dtheta_b_rad.x() += bias_rad_s * (d.imu[k].t_s - d.imu[k - 1].t_s);
  const GradeChoice c = choose_grade(d);
  EXPECT_EQ(c.grade, "mems") << c.rule;
  EXPECT_NEAR(c.gyro_bias_min_deg_h, 720.0, 20.0) << c.rule;  // >= |bias| - Earth rate
}

TEST(GradeChoice, DeclaredNoiseWinsAndNoStaticWindowIsSaidToBeAnAssumption) {
  Dataset d = measured_looking("mems");
  d.meta.noise = NoiseLevels{0.002, 0.001, 0.01, 0.02};
  EXPECT_EQ(choose_grade(d).grade, "nav");
  EXPECT_EQ(choose_grade(d).source, "meta.json noise");
  d.meta.noise.reset();
  d.meta.align_s = 0.0;
  const GradeChoice c = choose_grade(d);
  EXPECT_EQ(c.grade, "nav");
  EXPECT_EQ(c.source, "assumed");
  EXPECT_NE(c.rule.find("ASSUMED"), std::string::npos);
  EXPECT_EQ(choose_grade(d, "tactical").grade, "tactical");
  EXPECT_EQ(choose_grade(d, "tactical").source, "--grade");
  EXPECT_THROW(choose_grade(d, "consumer"), std::invalid_argument);
}

// One grade table (data/grade_table.h): the estimation grades, the simulator's noise
// grades and the window study read its figures, which before each wrote themselves. The figures
// are pinned to their physical values (the table at the top of grade_table.h), so a changed
// number fails here as well as a reader that stops reading the table.
TEST(GradeTable, EveryFormerCopyReadsTheSameFigures) {
  const double deg_h = kDegToRad / 3600.0, mg = 1e-3 * kStandardGravity_mps2;
  struct Pinned {
    const char* name;
    double gyro_rad_s, accel_mps2, scale, misalign_rad;
    NoiseLevels noise;
  };
  const Pinned pinned[] = {
      {"nav", 0.01 * deg_h, 0.0005, 1e-4, 1e-4, {0.002, 0.001, 0.01, 0.02}},
      {"tactical", 1.0 * deg_h, 1.0 * mg, 3e-4, 3e-4, {0.05, 0.02, 0.02, 0.1}},
      {"mems", 0.1 * kDegToRad, 10.0 * mg, 1e-3, 1e-3, {0.2, 0.05, 0.03, 0.5}}};
  ASSERT_EQ(grade_table().size(), std::size(pinned));
  for (const Pinned& p : pinned) {
    SCOPED_TRACE(p.name);
    const GradeFigures& row = grade_figures(p.name);
    EXPECT_NEAR(row.gyro_bias_rad_s, p.gyro_rad_s, 1e-15 * p.gyro_rad_s);
    EXPECT_NEAR(row.accel_bias_mps2, p.accel_mps2, 1e-15 * p.accel_mps2);
    EXPECT_EQ(row.scale, p.scale);
    EXPECT_EQ(row.misalign_rad, p.misalign_rad);
    EXPECT_EQ(row.noise.arw_deg_rth, p.noise.arw_deg_rth);
    EXPECT_EQ(row.noise.vrw_mps_rth, p.noise.vrw_mps_rth);
    EXPECT_EQ(row.noise.gnss_vel_sigma_mps, p.noise.gnss_vel_sigma_mps);
    EXPECT_EQ(row.noise.gnss_pos_sigma_m, p.noise.gnss_pos_sigma_m);

    // The estimation grade (identification/grade.h).
    const SensorGrade& grade = sensor_grade(p.name);
    EXPECT_EQ(grade.gyro_bias_rad_s, row.gyro_bias_rad_s);
    EXPECT_EQ(grade.accel_bias_mps2, row.accel_bias_mps2);
    EXPECT_EQ(grade.scale, row.scale);
    EXPECT_EQ(grade.misalign_rad, row.misalign_rad);
    EXPECT_EQ(grade.noise.arw_deg_rth, row.noise.arw_deg_rth);
    EXPECT_EQ(grade.noise.vrw_mps_rth, row.noise.vrw_mps_rth);
    EXPECT_EQ(grade.noise.gnss_vel_sigma_mps, row.noise.gnss_vel_sigma_mps);
    EXPECT_EQ(grade.noise.gnss_pos_sigma_m, row.noise.gnss_pos_sigma_m);
    if (std::string(p.name) == "tactical") continue;  // no simulator or window-study grade

    // The simulator's noise (scenarios/noise.cc).
    const NoiseLevels simulated = scenarios::noise_grade(p.name).levels();
    EXPECT_EQ(simulated.arw_deg_rth, row.noise.arw_deg_rth);
    EXPECT_EQ(simulated.vrw_mps_rth, row.noise.vrw_mps_rth);
    EXPECT_EQ(simulated.gnss_vel_sigma_mps, row.noise.gnss_vel_sigma_mps);
    EXPECT_EQ(simulated.gnss_pos_sigma_m, row.noise.gnss_pos_sigma_m);

    // The window study's sigmas (identification/window_study.h).
    const window_study::Grade study = window_study::grade(p.name);
    EXPECT_EQ(study.sigma_gyro_rad_s, row.gyro_bias_rad_s);
    EXPECT_EQ(study.sigma_accel_mps2, row.accel_bias_mps2);
  }
  // nav searches in the catalogue's units (model/sensor_errors.h).
  EXPECT_EQ(grade_figures("nav").gyro_bias_rad_s, kSigmaGyroRadS);
  EXPECT_EQ(grade_figures("nav").accel_bias_mps2, kSigmaAccelMps2);
  EXPECT_THROW(grade_figures("consumer"), std::invalid_argument);
}

}  // namespace
}  // namespace insid
