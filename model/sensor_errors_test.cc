#include "model/sensor_errors.h"

#include <random>
#include <set>

#include <gtest/gtest.h>

namespace insid {
namespace {

TEST(SensorErrors, CatalogueHasDesignNamesAndNoDuplicates) {
  std::set<std::string> names;
  for (const EffectInfo& e : effect_catalogue()) names.insert(std::string(e.name));
  EXPECT_EQ(names.size(), effect_catalogue().size());
  for (const char* n : {"accel_bias_x", "accel_bias_y", "gyro_bias_x", "gyro_bias_y", "gyro_bias_z",
                        "accel_scale_z", "gyro_scale_z", "accel_misalign_xy", "gyro_misalign_zx",
                        "accel_bias_drift_x", "gyro_bias_drift_y", "gnss_latency", "lever_arm_x"})
    EXPECT_TRUE(names.count(n)) << n;
  // (bias, scale, drift, motor offset) x 3 axes x 2 sensors + 6 misalignments x 2 + latency +
  // lever arm.
  EXPECT_EQ(names.size(), 4u * 3 * 2 + 6u * 2 + 1 + 3);
}

TEST(SensorErrors, UnknownNameListsValidOnes) {
  SensorErrors e;
  try {
    set_effect(e, "accel_bias_w", 1.0);
    FAIL() << "no exception";
  } catch (const std::invalid_argument& ex) {
    EXPECT_NE(std::string(ex.what()).find("accel_bias_w"), std::string::npos);
    EXPECT_NE(std::string(ex.what()).find("gyro_bias_x"), std::string::npos);
  }
  EXPECT_THROW(set_effect(e, "gyro_bias_x", std::nan("")), std::invalid_argument);
}

TEST(SensorErrors, SetGetRoundTripEveryEffect) {
  SensorErrors e;
  double v = 1.0;
  for (const EffectInfo& info : effect_catalogue()) set_effect(e, info.name, v++);
  v = 1.0;
  for (const EffectInfo& info : effect_catalogue()) EXPECT_EQ(get_effect(e, info.name), v++);
  EXPECT_EQ(nonzero_effects(e).size(), effect_catalogue().size());
  EXPECT_EQ(e.gyro.misalign(2, 0), get_effect(e, "gyro_misalign_zx"));
}

TEST(SensorErrors, CompensationInvertsApplicationExactly) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  SensorErrors e;
  for (const EffectInfo& info : effect_catalogue())
    if (info.side == EffectSide::kImu) set_effect(e, info.name, 3 * info.sigma * n(rng));
  const ImuCompensator comp(e);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d dtheta(n(rng) * 1e-2, n(rng) * 1e-2, n(rng) * 1e-2);
    const Eigen::Vector3d dv(n(rng) * 0.1, n(rng) * 0.1, n(rng) * 0.1);
    Eigen::Vector3d a = dtheta, b = dv;
    apply_imu_errors(e, 1000.0 + i, 0.01, a, b);
    EXPECT_GT((a - dtheta).norm(), 0.0);
    comp.compensate(1000.0 + i, 0.01, a, b);
    EXPECT_LT((a - dtheta).norm(), 1e-14 * dtheta.norm());
    EXPECT_LT((b - dv).norm(), 1e-14 * dv.norm());
  }
}

TEST(SensorErrors, ModelTermsHaveTheDocumentedMeaning) {
  SensorErrors e;
  e.accel.bias.x() = 1e-3;
  e.accel.bias_drift.x() = 1e-5;
  e.gyro.scale.z() = 1e-3;
  e.gyro.misalign(0, 1) = 2e-3;  // x sensor senses true y
  Eigen::Vector3d dtheta(0, 0.5, 1.0), dv(0, 0, 0);
  apply_imu_errors(e, 10.0, 0.01, dtheta, dv);
  EXPECT_NEAR(dv.x(), (1e-3 + 1e-5 * 9.995) * 0.01, 1e-18);  // bias integrates at mid-time
  EXPECT_NEAR(dtheta.z(), 1.0 * (1 + 1e-3), 1e-15);          // scale factor scales
  EXPECT_NEAR(dtheta.x(), 2e-3 * 0.5, 1e-15);                // misalignment M(x, y)
}

// The motor offset adds to the bias for the part of the step the motors ran, and compensation
// removes exactly what was applied (the alignment's window means too).
TEST(SensorErrors, MotorOffsetActsOnlyWhileTheMotorsRun) {
  SensorErrors e;
  e.gyro.bias.x() = 1e-4;
  e.gyro.motor_offset.x() = 5e-3;
  e.accel.motor_offset.z() = -0.2;
  const Eigen::Vector3d dtheta0(0.01, -0.02, 0.005), dv0(0.03, 0.01, -0.098);
  for (const double u : {0.0, 0.25, 1.0}) {
    Eigen::Vector3d dtheta = dtheta0, dv = dv0;
    apply_imu_errors(e, 10.0, 0.01, dtheta, dv, u);
    EXPECT_NEAR(dtheta.x() - dtheta0.x(), (1e-4 + 5e-3 * u) * 0.01, 1e-17) << u;
    EXPECT_NEAR(dv.z() - dv0.z(), -0.2 * u * 0.01, 1e-17) << u;
    ImuCompensator(e).compensate(10.0, 0.01, dtheta, dv, u);
    EXPECT_LT((dtheta - dtheta0).norm(), 1e-17) << u;
    EXPECT_LT((dv - dv0).norm(), 1e-16) << u;
  }
  MotorSchedule motors;
  motors.on_s = {{1.0, 2.0}, {3.0, 3.5}};
  EXPECT_EQ(motors.validate(), "");
  EXPECT_DOUBLE_EQ(motors.fraction(0.0, 1.0), 0.0);
  EXPECT_DOUBLE_EQ(motors.fraction(0.5, 1.5), 0.5);
  EXPECT_DOUBLE_EQ(motors.fraction(1.2, 1.3), 1.0);
  EXPECT_DOUBLE_EQ(motors.fraction(1.5, 3.5), 0.5);  // 0.5 s + 0.5 s of 2 s
  motors.on_s = {{1.0, 2.0}, {1.5, 3.0}};
  EXPECT_NE(motors.validate().find("motor interval 1"), std::string::npos) << motors.validate();
  motors.on_s = {{2.0, 1.0}};
  EXPECT_NE(motors.validate().find("must start before it ends"), std::string::npos);
}

// Each entry's typed fields say what its value moves: setting it changes exactly the model term
// its sensor, kind and axes name, and the typed look-up finds it again.
TEST(SensorErrors, TypedFieldsNameTheTermTheValueMoves) {
  for (const EffectInfo& info : effect_catalogue()) {
    SensorErrors e;
    set_effect(e, info.name, 0.5);
    double moved = 0.0;
    const TriadErrors& triad = info.sensor == EffectSensor::kGyro ? e.gyro : e.accel;
    switch (info.kind) {
      case EffectKind::kBias:
        moved = triad.bias[info.axis];
        break;
      case EffectKind::kBiasDrift:
        moved = triad.bias_drift[info.axis];
        break;
      case EffectKind::kScale:
        moved = triad.scale[info.axis];
        break;
      case EffectKind::kMisalign:
        moved = triad.misalign(info.axis, info.true_axis);
        break;
      case EffectKind::kMotorOffset:
        moved = triad.motor_offset[info.axis];
        break;
      case EffectKind::kLatency:
        moved = e.gnss_latency_s;
        break;
      case EffectKind::kLeverArm:
        moved = e.lever_arm_b_m[info.axis];
        break;
    }
    EXPECT_EQ(moved, 0.5) << info.name;
    EXPECT_EQ(info.side == EffectSide::kGnss, info.sensor == EffectSensor::kGnss) << info.name;
    EXPECT_EQ(&effect_info(info.sensor, info.kind, info.axis, info.true_axis),
              &effect_info(info.name))
        << info.name;
  }
  EXPECT_EQ(find_effect_info("gyro_bias_w"), nullptr);
  EXPECT_THROW(effect_info(EffectSensor::kGnss, EffectKind::kBias, 0), std::invalid_argument);
}

}  // namespace
}  // namespace insid
