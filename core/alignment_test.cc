#include "core/alignment.h"

#include <cmath>

#include <gtest/gtest.h>

#include "core/rotation.h"
#include "core/test_support.h"

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
    const Dataset ds = testing::make_static_dataset(earth, kLat, 0.0, 50.0, att, 600.0, 600.0);
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
  const Dataset ds = testing::make_static_dataset(earth, kLat, 0.0, 50.0, att, 600.0, 600.0, errors);
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
  const Dataset ds = testing::make_static_dataset(earth, kLat, 0.0, 50.0, att, 600.0, 600.0, errors);
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
  const Dataset ds = testing::make_static_dataset(earth, kLat, 0.0, 50.0, att, 600.0, 600.0, errors);
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

}  // namespace
}  // namespace insid
