#include "nav/alignment.h"

#include <cmath>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "model/rotation.h"
#include "test_support/test_support.h"

namespace insid {
namespace {

constexpr double kLat = 40.068 * kDegToRad;

AlignmentWindow window_of(const Dataset& ds) {
  return AlignmentWindow::from_imu(ds.imu, 0, ds.imu.size(), 0.0);
}

TEST(Alignment, ErrorFreeStaticDataAlignsExactly) {
  const EarthModel earth = EarthModel::paper(kLat, 50.0);
  for (double yaw_deg : {0.0, 45.0, 170.0, 260.0}) {
    const EulerAngles att{1.5 * kDegToRad, -2.0 * kDegToRad, yaw_deg * kDegToRad};
    const Dataset ds = test::make_static_dataset(earth, kLat, 0.0, 50.0, att, 600.0, 600.0);
    const Eigen::Matrix3d C = align_window(window_of(ds), ImuCompensator(SensorErrors{}));
    EXPECT_LT((C - C_b_n_from_euler(att)).norm(), 1e-9) << "yaw " << yaw_deg;
  }
}

// GIVEN a level IMU heading north with a horizontal accelerometer bias
// THEN the levelling error is the bias over g: the sensed "up" leans toward the biased axis,
// i.e. pitch error = +b_x / g and roll error = -b_y / g (tilt phi = -bias_n x up / g).
TEST(Alignment, LevellingErrorIsMinusBiasOverG) {
  const EarthModel earth = EarthModel::paper(kLat, 50.0);
  const double g = earth.normal_gravity_mps2(kLat, 50.0);
  const EulerAngles att{0, 0, 0};
  SensorErrors errors;
  errors.accel.bias = Eigen::Vector3d(3 * kSigmaAccelMps2, -2 * kSigmaAccelMps2, 0);
  const Dataset ds = test::make_static_dataset(earth, kLat, 0.0, 50.0, att, 600.0, 600.0, errors);
  const EulerAngles e = euler_from_C_b_n(align_window(window_of(ds), ImuCompensator({})));
  EXPECT_NEAR(e.pitch_rad, errors.accel.bias.x() / g, 0.05 * std::abs(errors.accel.bias.x() / g));
  EXPECT_NEAR(e.roll_rad, -errors.accel.bias.y() / g, 0.05 * std::abs(errors.accel.bias.y() / g));
  // Compensating the bias removes the error (O(1) re-alignment from the same window sums).
  const EulerAngles fixed = euler_from_C_b_n(align_window(window_of(ds), ImuCompensator(errors)));
  EXPECT_NEAR(fixed.pitch_rad, 0.0, 1e-10);
  EXPECT_NEAR(fixed.roll_rad, 0.0, 1e-10);
}

// GIVEN an east gyro bias eps_E THEN the gyrocompass heading error is eps_E / (W cos(lat)):
// the sensed east axis turns toward south, so the heading reads -eps_E / (W cos(lat)).
TEST(Alignment, HeadingErrorFromEastGyroBias) {
  const EarthModel earth = EarthModel::paper(kLat, 50.0);
  const EulerAngles att{0, 0, 0};  // body y axis = east
  SensorErrors errors;
  errors.gyro.bias.y() = 2 * kSigmaGyroRadS;
  const Dataset ds = test::make_static_dataset(earth, kLat, 0.0, 50.0, att, 600.0, 600.0, errors);
  const EulerAngles e = euler_from_C_b_n(align_window(window_of(ds), ImuCompensator({})));
  const double expected = -errors.gyro.bias.y() / (earth.omega_ie_rad_s * std::cos(kLat));
  EXPECT_NEAR(wrap_pi(e.yaw_rad), expected, 0.05 * std::abs(expected));
  EXPECT_GT(std::abs(expected), 1e-4);  // ~0.6 mrad: large enough to be a meaningful check
}

TEST(Alignment, DriftCompensationUsesWindowMeanTime) {
  const EarthModel earth = EarthModel::paper(kLat, 50.0);
  const EulerAngles att{0.01, 0.02, 1.0};
  SensorErrors errors;
  errors.accel.bias_drift = Eigen::Vector3d(1e-6, -2e-6, 3e-7);
  errors.gyro.bias_drift = Eigen::Vector3d(1e-11, 2e-11, -1e-11);
  errors.accel.scale = Eigen::Vector3d(1e-4, -2e-4, 3e-4);
  errors.gyro.misalign(0, 1) = 2e-4;
  const Dataset ds = test::make_static_dataset(earth, kLat, 0.0, 50.0, att, 600.0, 600.0, errors);
  const Eigen::Matrix3d C = align_window(window_of(ds), ImuCompensator(errors));
  EXPECT_LT((C - C_b_n_from_euler(att)).norm(), 1e-9);
  const Eigen::Matrix3d C_uncompensated = align_window(window_of(ds), ImuCompensator({}));
  EXPECT_GT((C_uncompensated - C_b_n_from_euler(att)).norm(), 1e-5);
}

TEST(Alignment, ParallelVectorsAreRejected) {
  EXPECT_THROW(coarse_align(Eigen::Vector3d(0, 0, -9.8), Eigen::Vector3d(0, 0, 1e-5)),
               std::invalid_argument);
  EXPECT_THROW(coarse_align(Eigen::Vector3d::Zero(), Eigen::Vector3d(1e-5, 0, 0)),
               std::invalid_argument);
}

// level_with_yaw(f, yaw of the gyrocompass) is the gyrocompass attitude: roll and pitch from the
// same up direction, at tilts and headings all round.
TEST(Alignment, LevellingWithTheGyrocompassYawIsTheCoarseAlignment) {
  const EarthModel earth = EarthModel::paper(kLat, 50.0);
  for (double yaw_deg : {0.0, 45.0, 170.0, 260.0})
    for (double roll_deg : {-20.0, 0.0, 3.0}) {
      const EulerAngles att{roll_deg * kDegToRad, 7.0 * kDegToRad, yaw_deg * kDegToRad};
      const Dataset ds = test::make_static_dataset(earth, kLat, 0.0, 50.0, att, 60.0, 60.0);
      const AlignmentWindow w = window_of(ds);
      const Eigen::Matrix3d C = align_window(w, ImuCompensator(SensorErrors{}));
      const Eigen::Matrix3d L =
          level_with_yaw(w.sum_dv_b / w.sum_dt_s, euler_from_C_b_n(C).yaw_rad);
      EXPECT_LT((L - C).norm(), 1e-12) << roll_deg << " " << yaw_deg;
      EXPECT_LT((L - C_b_n_from_euler(att)).norm(), 1e-9);
    }
}

// The O(1) projected compensation equals the sum over compensated increments (general model:
// bias, drift, scale, misalignment) for random directions and increments.
TEST(Alignment, ProjectedGyroSumEqualsTheSumOfCompensatedIncrements) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  SensorErrors errors;
  errors.gyro.bias = Eigen::Vector3d(u(rng), u(rng), u(rng)) * 1e-2;
  errors.gyro.bias_drift = Eigen::Vector3d(u(rng), u(rng), u(rng)) * 1e-6;
  errors.gyro.scale = Eigen::Vector3d(u(rng), u(rng), u(rng)) * 1e-2;
  errors.gyro.misalign(0, 1) = 3e-3;
  errors.gyro.misalign(2, 0) = -2e-3;
  const ImuCompensator compensator(errors);
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  Eigen::Vector3d U = Eigen::Vector3d::Zero(), V = Eigen::Vector3d::Zero();
  double direct = 0.0, t = 10.0;
  for (int k = 0; k < 500; ++k) {
    const double dt = 0.005 + 0.005 * (u(rng) + 1.0);
    t += dt;
    const Eigen::Vector3d dir = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
    Eigen::Vector3d dtheta = Eigen::Vector3d(u(rng), u(rng), u(rng)) * 0.01,
                    dv = Eigen::Vector3d::Zero();
    M += dir * dtheta.transpose();
    U += dir * dt;
    V += dir * ((t - 0.5 * dt) * dt);
    compensator.compensate(t, dt, dtheta, dv);
    direct += dir.dot(dtheta);
  }
  EXPECT_NEAR(compensator.projected_gyro_sum(M, U, V), direct, 1e-12 * (1.0 + std::abs(direct)));
  EXPECT_GT(std::abs(direct - ImuCompensator(SensorErrors{}).projected_gyro_sum(M, U, V)), 1e-4);
}

TEST(Alignment, ModeNamesAndOptionsAreChecked) {
  EXPECT_EQ(initial_attitude_mode_from_string("align"), InitialAttitudeMode::kGyrocompass);
  for (InitialAttitudeMode m :
       {InitialAttitudeMode::kGyrocompass, InitialAttitudeMode::kLevelHeading,
        InitialAttitudeMode::kGiven, InitialAttitudeMode::kTruth})
    EXPECT_EQ(initial_attitude_mode_from_string(to_string(m)), m);
  try {
    initial_attitude_mode_from_string("magnetometer");
    ADD_FAILURE() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("got 'magnetometer'"), std::string::npos) << e.what();
  }
  InitialAttitudeOptions o;
  EXPECT_EQ(o.validate(), "");
  o.heading_deg = 10.0;  // only for level+heading
  EXPECT_NE(o.validate().find("only used by --initial-attitude level+heading"), std::string::npos);
  o.mode = InitialAttitudeMode::kLevelHeading;
  EXPECT_EQ(o.validate(), "");
  o.course_min_speed_mps = -1.0;
  EXPECT_NE(o.validate().find("course_min_speed_mps must be a finite number > 0, got -1"),
            std::string::npos);
}

// The feasibility figure: nav grade over 600 s at the paper's latitude with the paper box
// (4 sigma = 0.04 deg/h) is about 0.2 deg; it is the ARW term alone with no bias allowance.
TEST(Alignment, GyrocompassFeasibilityFigures) {
  const double W = 7.292115e-5, arw = 0.002 * kDegToRad / 60.0;
  const GyrocompassFeasibility nav =
      gyrocompass_feasibility(arw, true, 600.0, 4 * kSigmaGyroRadS, W, kLat);
  const double expected =
      std::hypot(arw / std::sqrt(600.0), 4 * kSigmaGyroRadS) / (W * std::cos(kLat));
  EXPECT_DOUBLE_EQ(nav.heading_sd_rad, expected);
  EXPECT_NEAR(nav.heading_sd_rad * kRadToDeg, 0.2, 0.01);
  const GyrocompassFeasibility noise_only = gyrocompass_feasibility(arw, true, 600.0, 0.0, W, kLat);
  EXPECT_DOUBLE_EQ(noise_only.heading_sd_rad, arw / std::sqrt(600.0) / (W * std::cos(kLat)));
  EXPECT_NE(nav.describe().find("declared in meta.json"), std::string::npos) << nav.describe();
}

}  // namespace
}  // namespace insid
