#include "model/rotation.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

namespace insid {
namespace {

TEST(Rotation, EulerRoundTripAtIdentityTinyAndRandom) {
  std::mt19937 rng(42);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<EulerAngles> cases = {{0, 0, 0}, {1e-9, -1e-9, 1e-9}};
  for (int i = 0; i < 200; ++i)
    cases.push_back({u(rng) * kPi, u(rng) * (kPi / 2 - 1e-3), u(rng) * kPi});
  for (const EulerAngles& e : cases) {
    const Eigen::Matrix3d C = C_b_n_from_euler(e);
    EXPECT_NEAR((C * C.transpose() - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-14);
    EXPECT_NEAR(C.determinant(), 1.0, 1e-14);
    const EulerAngles back = euler_from_C_b_n(C);
    EXPECT_NEAR(back.roll_rad, e.roll_rad, 1e-9);
    EXPECT_NEAR(back.pitch_rad, e.pitch_rad, 1e-9);
    EXPECT_NEAR(wrap_pi(back.yaw_rad - e.yaw_rad), 0.0, 1e-9);
    const EulerAngles via_q = euler_from_q_b_n(q_b_n_from_euler(e));
    EXPECT_NEAR(via_q.roll_rad, e.roll_rad, 1e-9);
    EXPECT_NEAR(via_q.pitch_rad, e.pitch_rad, 1e-9);
    EXPECT_NEAR(wrap_pi(via_q.yaw_rad - e.yaw_rad), 0.0, 1e-9);
  }
}

TEST(Rotation, ConventionsFrdToEnu) {
  // Level, heading north: forward = north, right = east, down = -up.
  Eigen::Matrix3d C = C_b_n_from_euler({0, 0, 0});
  EXPECT_TRUE(C.col(0).isApprox(Eigen::Vector3d(0, 1, 0)));
  EXPECT_TRUE(C.col(1).isApprox(Eigen::Vector3d(1, 0, 0)));
  EXPECT_TRUE(C.col(2).isApprox(Eigen::Vector3d(0, 0, -1)));
  // Heading east (yaw +90 deg, clockwise from north): forward = east.
  C = C_b_n_from_euler({0, 0, kPi / 2});
  EXPECT_NEAR((C.col(0) - Eigen::Vector3d(1, 0, 0)).norm(), 0.0, 1e-15);
  // Nose up 10 deg: forward has a positive up component.
  C = C_b_n_from_euler({0, 10 * kDegToRad, 0});
  EXPECT_NEAR(C.col(0).z(), std::sin(10 * kDegToRad), 1e-15);
  // Right wing down 10 deg: the right axis points partly down (negative up).
  C = C_b_n_from_euler({10 * kDegToRad, 0, 0});
  EXPECT_NEAR(C.col(1).z(), -std::sin(10 * kDegToRad), 1e-15);
}

TEST(Rotation, RotationVectorRoundTrip) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d phi(u(rng), u(rng), u(rng));
    const Eigen::Quaterniond q = quat_from_rotation_vector(phi);
    EXPECT_NEAR(q.norm(), 1.0, 1e-15);
    EXPECT_NEAR((rotation_vector_from_quat(q) - phi).norm(), 0.0, 1e-12);
    const Eigen::AngleAxisd aa(phi.norm(), phi.normalized());
    EXPECT_TRUE(q.toRotationMatrix().isApprox(aa.toRotationMatrix(), 1e-13));
  }
  const Eigen::Vector3d tiny(1e-10, -2e-10, 3e-10);
  EXPECT_NEAR((rotation_vector_from_quat(quat_from_rotation_vector(tiny)) - tiny).norm(), 0, 1e-20);
}

TEST(Rotation, Wrap) {
  EXPECT_NEAR(wrap_pi(3 * kPi / 2), -kPi / 2, 1e-15);
  EXPECT_NEAR(wrap_two_pi(-kPi / 2), 3 * kPi / 2, 1e-15);
  EXPECT_NEAR(wrap_pi(-kPi), kPi, 1e-15);
}

}  // namespace
}  // namespace insid
