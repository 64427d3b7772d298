// The gyro biases measured at rest (nav/gyro_at_rest.h): the static window's mean rate, less
// the Earth rate, as the motors-off bias, so that a motor offset is told apart from it on a
// flight whose motors start where the window ends (no motors-off navigation at all).
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <numbers>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "identification/grade.h"
#include "identification/identify_run.h"
#include "import/import_recording.h"
#include "model/units.h"
#include "nav/gyro_at_rest.h"
#include "scenarios/noise.h"
#include "scenarios/scenario.h"

namespace insid {
namespace {

constexpr double kGyroBiasX = 0.2 * kDegToRad, kGyroBiasY = -0.15 * kDegToRad;
constexpr double kOffsetX = 0.3 * kDegToRad, kOffsetY = -0.2 * kDegToRad;

// A MEMS multicopter flight, 30 s static then 250 s of flight; the motors run from the end of the
// static window to the end, with an offset of 0.3 / -0.2 deg/s (x / y) on top of motors-off
// biases of 0.2 / -0.15 deg/s.
std::shared_ptr<const Dataset> flight(bool with_offset, const std::string& grade = "mems") {
  scenarios::ScenarioConfig cfg = scenarios::preset_scenario("multicopter");
  cfg.align_s = 30.0;
  cfg.flight_s = 250.0;
  cfg.noise = scenarios::noise_grade(grade);
  cfg.seed = 5;
  cfg.injected = SensorErrors{};
  set_effect(cfg.injected, "gyro_bias_x", kGyroBiasX);
  set_effect(cfg.injected, "gyro_bias_y", kGyroBiasY);
  if (with_offset) {
    set_effect(cfg.injected, "gyro_motor_offset_x", kOffsetX);
    set_effect(cfg.injected, "gyro_motor_offset_y", kOffsetY);
  }
  cfg.motors.on_s = {{cfg.align_s, cfg.align_s + *cfg.flight_s + 10.0}};
  return std::make_shared<const Dataset>(scenarios::simulate(cfg));
}

IdentifySpec spec_for(const std::shared_ptr<const Dataset>& data) {
  IdentifySpec s;
  s.dataset = data;
  s.algorithm = "lm";
  s.estimate = {"gyro_motor_offset_x", "gyro_motor_offset_y", "gyro_motor_offset_z", "accel_bias_x",
                "accel_bias_y"};
  s.grade = "mems";
  s.iterations = 0;
  s.evaluations = 200;
  s.window_s = 10.0;
  s.initial_attitude.mode = InitialAttitudeMode::kLevelHeading;
  s.reference_optimum = false;
  s.uncertainty_replicas = 30;
  s.threads = 2;
  s.gyro_bias_at_rest = true;
  return s;
}

const nlohmann::json& parameter(const IdentifyReport& r, const std::string& name) {
  for (const nlohmann::json& p : r.result.at("parameters"))
    if (p.at("name") == name) return p;
  throw std::runtime_error(name + " not in the result");
}

// The window's mean rate less the Earth rate is the motors-off bias, within 4 of its own sd.
TEST(GyroAtRest, TheStaticWindowMeasuresTheMotorsOffBias) {
  const auto data = flight(true);
  NavigationOptions options;
  options.initial_attitude.mode = InitialAttitudeMode::kLevelHeading;
  const NavigationProblem nav(data, options);
  const GyroAtRest rest = gyro_at_rest(nav);
  const Eigen::Vector3d bias = rest.bias_for(TriadErrors{});
  const Eigen::Vector3d truth(kGyroBiasX, kGyroBiasY, 0.0);
  std::cout << "at rest: " << bias.transpose() * kRadToDeg << " deg/s, sd "
            << rest.sd_of_mean_rad_s.transpose() * kRadToDeg << ", Earth rate "
            << rest.omega_ie_b.transpose() * kRadToDeg << "\n";
  for (int i = 0; i < 3; ++i) {
    EXPECT_GT(rest.sd_of_mean_rad_s[i], 0.0);
    EXPECT_LE(std::abs(bias[i] - truth[i]), 4.0 * rest.sd_of_mean_rad_s[i]) << i;
  }
  EXPECT_NEAR(rest.omega_ie_b.norm(), data->meta.earth.omega_ie_rad_s, 1e-12);
  EXPECT_EQ(rest.motor_on_mean, 0.0);
}

// Refused, naming why: a window the motors ran in; gyrocompassing (which reads the same rate
// as the Earth rate); both the rest measurement and a gyro bias estimated.
TEST(GyroAtRest, RefusesWhatItCannotMeasure) {
  auto data = std::make_shared<Dataset>(*flight(false));
  data->meta.motors.on_s = {{20.0, 400.0}};
  NavigationOptions options;
  options.initial_attitude.mode = InitialAttitudeMode::kLevelHeading;
  try {
    gyro_at_rest(NavigationProblem(data, options));
    ADD_FAILURE() << "a window with the motors on was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("the motors off"), std::string::npos) << e.what();
  }
  options.initial_attitude.mode = InitialAttitudeMode::kGyrocompass;
  try {  // navigation-grade gyros, which can gyrocompass
    gyro_at_rest(NavigationProblem(flight(false, "nav"), options));
    ADD_FAILURE() << "gyrocompassing was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("gyrocompassing"), std::string::npos) << e.what();
  }
  IdentifySpec s = spec_for(flight(false));
  s.estimate.push_back("gyro_bias_x");
  try {
    identify(s);
    ADD_FAILURE() << "gyro_bias_x estimated beside the rest measurement";
  } catch (const IdentifySpecError& e) {
    EXPECT_EQ(e.field(), "estimate");
    EXPECT_NE(std::string(e.what()).find("measured at rest"), std::string::npos) << e.what();
  }
  s = spec_for(flight(false));
  s.algorithm = "ekf-rts";
  EXPECT_NE(s.validate().find("gyro_bias_at_rest"), std::string::npos) << s.validate();
}

// GIVEN motor offsets of 0.3 / -0.2 deg/s that run from the end of the static window on
// WHEN identify (lm) measures the gyro biases at rest and estimates the offsets
// THEN each offset lies within 3 sd of the truth with an sd below a third of it, and z (no
// offset) within 3 sd of 0; the result records the rest measurement.
// WITHOUT the rest measurement (bias and offset both estimated) the flight sees only their sum:
// the offsets are flagged not_observable, without an sd.
TEST(GyroAtRest, ToldApartFromTheMotorOffsetWithoutMotorsOffNavigation) {
  const auto data = flight(true);
  const IdentifyReport r = identify(spec_for(data));
  const double truth[3] = {kOffsetX, kOffsetY, 0.0};
  const char* names[3] = {"gyro_motor_offset_x", "gyro_motor_offset_y", "gyro_motor_offset_z"};
  for (int i = 0; i < 3; ++i) {
    const nlohmann::json& p = parameter(r, names[i]);
    const double estimate = p.at("estimate").get<double>(), sd = p.at("sd").get<double>();
    std::cout << names[i] << ": " << estimate * kRadToDeg << " +- " << sd * kRadToDeg
              << " deg/s (truth " << truth[i] * kRadToDeg << ")\n";
    EXPECT_LE(std::abs(estimate - truth[i]), 3.0 * sd) << p.dump();
    EXPECT_LT(sd, 0.1 * kDegToRad) << p.dump();
  }
  const nlohmann::json& rest = r.result.at("gyro_bias_at_rest");
  EXPECT_NEAR(rest.at("bias_deg_s").at(0).get<double>(), 0.2, 0.05) << rest.dump();
  EXPECT_NEAR(rest.at("window_s").at(1).get<double>(), 30.0, 0.05) << rest.dump();

  IdentifySpec both = spec_for(data);
  both.gyro_bias_at_rest = false;
  both.estimate.insert(both.estimate.begin(), {"gyro_bias_x", "gyro_bias_y", "gyro_bias_z"});
  const IdentifyReport sum_only = identify(both);
  for (int i = 0; i < 2; ++i) {
    const nlohmann::json& p = parameter(sum_only, names[i]);
    std::cout << "without the rest measurement " << names[i] << ": " << p.at("sd_reason") << "\n";
    EXPECT_TRUE(p.at("sd").is_null()) << p.dump();
    EXPECT_EQ(p.at("flags"), nlohmann::json::array({"not_observable"})) << p.dump();
  }
}

// GIVEN the shared quadcopter log's IMU3 (boot 74.7-215 s, the static window ending 0.08 s
// before the motors start) and a copy with +0.3 deg/s added on gyro x while the motors run (the
// background stays real: its own offsets, vibration, misfit) WHEN identify (lm, gyro biases at
// rest) runs on both THEN the x offset moves by 0.3 deg/s within 3 of its sd, and y and z move
// by less than 2 of theirs.
TEST(GyroAtRest, AnOffsetInjectedIntoTheRealLogMovesItsEstimateByItsSize) {
  const std::filesystem::path log =
      std::filesystem::path(INSID_SHARED_DATA) / "ardupilot-copter" / "log171.bin";
  if (!std::filesystem::exists(log))
    GTEST_SKIP() << "../shared/data/ardupilot-copter/log171.bin is absent (tests that need the "
                    "shared real data skip without it)";
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("insid-rest-inject-" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  importers::ImportSpec spec;
  importers::ArduPilotImportSource source;
  source.log_path = log.string();
  source.options.imu = "IMU3";
  source.options.t_start_s = 74.7;
  source.options.t_end_s = 215.0;
  spec.source = source;
  spec.assembly.align_s = 7.9;
  spec.out_dir = dir.string();
  const importers::ImportReport imported = importers::import_recording(spec);
  ASSERT_EQ(imported.datasets.size(), 1u);
  const std::shared_ptr<const Dataset> real = imported.datasets[0].dataset;

  const double injected = 0.3 * kDegToRad;
  auto with_offset = std::make_shared<Dataset>(*real);
  SensorErrors e;
  set_effect(e, "gyro_motor_offset_x", injected);
  for (std::size_t k = 1; k < with_offset->imu.size(); ++k) {
    ImuSample& s = with_offset->imu[k];
    const double t_before = with_offset->imu[k - 1].t_s;
    apply_imu_errors(e, s.t_s, s.t_s - t_before, s.dtheta_b_rad, s.dv_b_mps,
                     with_offset->meta.motors.fraction(t_before, s.t_s));
  }
  IdentifySpec id = spec_for(real);
  id.estimate = {"gyro_motor_offset_x", "gyro_motor_offset_y", "gyro_motor_offset_z",
                 "accel_bias_z"};
  id.uncertainty_replicas = 40;
  const IdentifyReport before = identify(id);
  id.dataset = with_offset;
  const IdentifyReport after = identify(id);
  const char* names[3] = {"gyro_motor_offset_x", "gyro_motor_offset_y", "gyro_motor_offset_z"};
  for (int i = 0; i < 3; ++i) {
    const nlohmann::json& a = parameter(before, names[i]);
    const nlohmann::json& b = parameter(after, names[i]);
    const double shift = b.at("estimate").get<double>() - a.at("estimate").get<double>();
    const double sd = b.at("sd").get<double>();
    std::cout << names[i] << ": real " << a.at("estimate").get<double>() * kRadToDeg
              << ", with the injection " << b.at("estimate").get<double>() * kRadToDeg << " +- "
              << sd * kRadToDeg << " deg/s: moved " << shift * kRadToDeg << "\n";
    EXPECT_LE(std::abs(shift - (i == 0 ? injected : 0.0)), (i == 0 ? 3.0 : 2.0) * sd) << b.dump();
    EXPECT_LT(sd, injected) << b.dump();  // an answer, not an interval that holds anything
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace insid
