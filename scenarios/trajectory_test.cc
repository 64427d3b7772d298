#include "scenarios/trajectory.h"

#include <cmath>
#include <stdexcept>

#include <gtest/gtest.h>

#include "scenarios/scenario.h"

namespace insid::scenarios {
namespace {

TEST(SmoothChannel, ValueRateAndIntegralAreConsistentAndContinuous) {
  // GIVEN a channel with two transitions and a gap between them
  SmoothChannel c(1.0);
  c.ramp(2.0, 3.0, 4.0);
  c.ramp(7.0, 1.5, -2.0);
  // THEN the rate is the derivative of the value, and the integral's derivative is the value
  for (double t = -1.0; t < 10.0; t += 0.0137) {
    const double h = 1e-5;
    EXPECT_NEAR(c.rate(t), (c.value(t + h) - c.value(t - h)) / (2 * h), 1e-8) << t;
    EXPECT_NEAR(c.value(t), (c.integral(t + h) - c.integral(t - h)) / (2 * h), 1e-7) << t;
  }
  // AND value and rate are continuous at every breakpoint
  for (double t : {2.0, 5.0, 7.0, 8.5}) {
    EXPECT_NEAR(c.value(t - 1e-12), c.value(t + 1e-12), 1e-10);
    EXPECT_NEAR(c.rate(t - 1e-12), c.rate(t + 1e-12), 1e-10);
  }
  EXPECT_DOUBLE_EQ(c.value(6.0), 4.0);
  EXPECT_DOUBLE_EQ(c.value(100.0), -2.0);
  // integral over a full transition is T * (from + to) / 2
  EXPECT_NEAR(c.integral(5.0) - c.integral(2.0), 3.0 * 2.5, 1e-12);
}

TEST(SmoothChannel, RejectsOverlapAndBadDurations) {
  SmoothChannel c;
  c.ramp(0.0, 1.0, 1.0);
  EXPECT_THROW(c.ramp(0.5, 1.0, 2.0), std::invalid_argument);
  EXPECT_THROW(c.ramp(2.0, 0.0, 2.0), std::invalid_argument);
  EXPECT_THROW(c.ramp(2.0, -1.0, 2.0), std::invalid_argument);
}

// The analytic derivatives must match finite differences of the analytic states: dv/dt = a_n,
// dh/dt = vU, dC_b_n/dt = C_b_n [omega_nb_b x], over a whole manoeuvre-rich flight.
TEST(Trajectory, AnalyticDerivativesMatchFiniteDifferences) {
  const ScenarioPlan plan = plan_scenario(preset_scenario("rich"));
  const Trajectory& traj = plan.trajectory;
  double max_a = 0, max_w = 0, max_h = 0;
  for (double t = 590.0; t < 600.0 + plan.flight_s; t += 1.37) {
    const double h = 1e-4;
    const Kinematics k = traj.eval(t), kp = traj.eval(t + h), km = traj.eval(t - h);
    const Eigen::Vector3d a_fd = (kp.v_eb_n - km.v_eb_n) / (2 * h);
    max_a = std::max(max_a, (a_fd - k.a_n).norm());
    max_h = std::max(max_h, std::fabs((kp.h_m - km.h_m) / (2 * h) - k.v_eb_n.z()));
    const Eigen::Matrix3d Cdot = (kp.C_b_n - km.C_b_n) / (2 * h);
    const Eigen::Matrix3d Omega = k.C_b_n.transpose() * Cdot;  // = [omega_nb_b x]
    const Eigen::Vector3d w_fd(Omega(2, 1), Omega(0, 2), Omega(1, 0));
    max_w = std::max(max_w, (w_fd - k.omega_nb_b).norm());
  }
  EXPECT_LT(max_a, 1e-6);
  EXPECT_LT(max_w, 1e-7);
  EXPECT_LT(max_h, 1e-7);
}

TEST(Trajectory, CoordinatedTurnBanksTheRightWayAndTurnsTheRightAngle) {
  InitialPose p;
  p.lat_rad = 0.7;
  TrajectoryBuilder b(p, 9.8);
  b.takeoff(50, 2, 2);
  b.change_speed(20, 1.0);
  const double t_turn = b.now_s();
  b.turn(90 * kDegToRad, TurnDirection::kRight, {20 * kDegToRad, 0.0}, 3.0);
  const double t_end = b.now_s();
  const Trajectory traj = b.build();
  // Mid-turn: right wing down (roll > 0) at the commanded bank, heading increasing.
  const Kinematics mid = traj.eval(0.5 * (t_turn + t_end));
  EXPECT_NEAR(mid.attitude.roll_rad, 20 * kDegToRad, 1e-9);
  EXPECT_GT(mid.omega_nb_b.z(), 0.0);  // yawing right about body down
  // After the turn: heading changed by exactly 90 deg, level again.
  const Kinematics end = traj.eval(t_end);
  EXPECT_NEAR(end.attitude.yaw_rad - traj.eval(t_turn).attitude.yaw_rad, 90 * kDegToRad, 1e-12);
  EXPECT_NEAR(end.attitude.roll_rad, 0.0, 1e-12);
  EXPECT_NEAR(end.v_eb_n.x(), 20.0, 1e-9);  // flying east
}

TEST(TrajectoryBuilder, RejectsBadSegments) {
  InitialPose p;
  p.lat_rad = 0.7;
  TrajectoryBuilder b(p, 9.8);
  EXPECT_THROW(b.straight(0.0), std::invalid_argument);
  EXPECT_THROW(b.straight(-5.0), std::invalid_argument);
  EXPECT_THROW(b.turn(kPi / 2, TurnDirection::kLeft, {30 * kDegToRad, 0.0}, 3.0),
               std::invalid_argument);  // bank turn needs speed
  b.change_speed(20, 1);
  EXPECT_THROW(b.hold_static(10), std::invalid_argument);  // moving
  EXPECT_THROW(b.turn(kPi / 2, TurnDirection::kLeft, {70 * kDegToRad, 0.0}, 3.0),
               std::invalid_argument);  // bank out of range
  EXPECT_THROW(b.turn(kPi / 2, TurnDirection::kLeft, {0.0, 0.0}, 3.0), std::invalid_argument);
  EXPECT_THROW(b.turn(1 * kDegToRad, TurnDirection::kLeft, {30 * kDegToRad, 0.0}, 3.0),
               std::invalid_argument);                          // shorter than its ramps
  EXPECT_THROW(b.climb(1.0, 2.0, 3.0), std::invalid_argument);  // shorter than its ramps
  const double t = b.now_s();
  EXPECT_EQ(b.now_s(), t);  // unchanged after the throws
}

}  // namespace
}  // namespace insid::scenarios
