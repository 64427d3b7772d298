#include "scenarios/scenario.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "data/dataset.h"
#include "model/sensor_errors.h"
#include "scenarios/synthesis.h"
#include "test_support/files.h"

namespace insid::scenarios {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

json base_json() {
  return json::parse(R"({
    "name": "effects", "imu_rate_hz": 100, "gnss_rate_hz": 20,
    "earth": {"model": "paper"},
    "initial": {"lat_deg": 40.068, "lon_deg": 116.246, "h_m": 50, "yaw_deg": 10},
    "align_s": 20,
    "segments": [
      {"type": "takeoff", "dh_m": 10, "vz_mps": 2},
      {"type": "speed", "speed_mps": 15, "accel_mps2": 1.0},
      {"type": "turn", "turn_deg": 180, "direction": "left", "rate_deg_s": 10}
    ]
  })");
}

ScenarioConfig base_config() { return parse_scenario(base_json(), "effects"); }

std::string expect_invalid(const json& j) {
  try {
    parse_scenario(j, "bad.json");
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  ADD_FAILURE() << "no error for " << j.dump();
  return {};
}

// ----- injected effects, each with its sign and size --------------------------------------------

struct Pair {
  Dataset clean, with;
};

Pair simulate_with(const std::string& effect, double value) {
  ScenarioConfig c = base_config();
  Pair p{simulate(c), {}};
  set_effect(c.injected, effect, value);
  p.with = simulate(c);
  return p;
}

TEST(Effects, AccelBiasAddsBiasTimesDt) {
  const Pair p = simulate_with("accel_bias_x", 1e-3);
  for (std::size_t k : {0, 3000, 5000}) {
    EXPECT_NEAR(p.with.imu[k].dv_b_mps.x() - p.clean.imu[k].dv_b_mps.x(), 1e-3 * 0.01, 1e-15);
    EXPECT_EQ(p.with.imu[k].dv_b_mps.y(), p.clean.imu[k].dv_b_mps.y());
  }
  EXPECT_EQ(p.with.meta.injected->at("accel_bias_x"), 1e-3);
}

TEST(Effects, GyroBiasAndDriftAddRateTimesDt) {
  const Pair p = simulate_with("gyro_bias_y", -2e-6);
  EXPECT_NEAR(p.with.imu[4000].dtheta_b_rad.y() - p.clean.imu[4000].dtheta_b_rad.y(), -2e-8, 1e-20);
  const Pair d = simulate_with("gyro_bias_drift_z", 1e-8);  // rad/s^2, linear from t = 0
  const ImuSample& s = d.with.imu[4000];
  EXPECT_NEAR(s.dtheta_b_rad.z() - d.clean.imu[4000].dtheta_b_rad.z(),
              1e-8 * (s.t_s - 0.005) * 0.01, 1e-20);
}

// A motor offset adds to the increments only while the motors run (a step inside an IMU
// interval: that step gets its part), is written with the schedule to meta.json, and is refused
// without a schedule.
TEST(Effects, MotorOffsetActsWhileTheMotorsRun) {
  ScenarioConfig c = base_config();
  const Dataset clean = simulate(c);
  set_effect(c.injected, "gyro_motor_offset_y", 1e-3);
  EXPECT_THROW(simulate(c), std::invalid_argument);
  const double t_on = clean.imu[3000].t_s - 0.25 * 0.01;  // a quarter step before row 3000
  c.motors.on_s = {{t_on, clean.imu[5000].t_s}};
  const Dataset with = simulate(c);
  const auto added = [&](std::size_t k) {
    return with.imu[k].dtheta_b_rad.y() - clean.imu[k].dtheta_b_rad.y();
  };
  EXPECT_EQ(added(2999), 0.0);
  EXPECT_NEAR(added(3000), 1e-3 * 0.25 * 0.01, 1e-17);
  EXPECT_NEAR(added(4000), 1e-3 * 0.01, 1e-17);
  EXPECT_EQ(added(5001), 0.0);
  ASSERT_EQ(with.meta.motors.on_s.size(), 1u);
  EXPECT_EQ(with.meta.motors.on_s[0].first, t_on);
}

TEST(Effects, ScaleFactorScalesTheIncrement) {
  const Pair p = simulate_with("accel_scale_z", 1e-3);
  for (std::size_t k : {0, 3000}) {
    const double truth = p.clean.imu[k].dv_b_mps.z();
    EXPECT_NEAR(p.with.imu[k].dv_b_mps.z(), (1 + 1e-3) * truth, 1e-15);
  }
  const Pair g = simulate_with("gyro_scale_z", -5e-4);
  // during the turn the z gyro sees the turn rate
  const double truth = g.clean.imu[5000].dtheta_b_rad.z();
  EXPECT_GT(std::fabs(truth), 1e-3);
  EXPECT_NEAR(g.with.imu[5000].dtheta_b_rad.z(), (1 - 5e-4) * truth, 1e-16);
}

TEST(Effects, MisalignmentCouplesTheOtherAxis) {
  // accel_misalign_xz: sensor x senses true z (gravity): dv_x grows by m * dv_z.
  const Pair p = simulate_with("accel_misalign_xz", 2e-4);
  const ImuSample& c = p.clean.imu[100];
  EXPECT_NEAR(p.with.imu[100].dv_b_mps.x() - c.dv_b_mps.x(), 2e-4 * c.dv_b_mps.z(), 1e-16);
  EXPECT_LT(c.dv_b_mps.z(), -0.09);  // FRD: gravity reaction points up = -z
}

TEST(Effects, LatencyShiftsGnssVelocityByAccelerationTimesLatency) {
  const double tau = 0.05;
  const Pair p = simulate_with("gnss_latency", tau);
  // During the acceleration to 15 m/s (after the 10 m take-off at t ~ 27 s).
  ScenarioConfig c = base_config();
  const ScenarioPlan plan = plan_scenario(c);
  ImuSynthesizer synth(plan.trajectory, c.earth, c.imu_rate_hz, c.substeps);
  synth.run(plan.num_imu_steps);
  int checked = 0;
  for (std::size_t j = 0; j < p.with.gnss.size(); ++j) {
    const double t = p.with.gnss[j].t_s;
    if (t < tau) continue;
    // v(t - tau) - v(t) = -a(t - tau/2) tau + O(tau^3 d2a/dt2)
    const TrueState s = synth.state_at(t - 0.5 * tau);
    if (s.a_n.head<2>().norm() < 0.5) continue;
    const Eigen::Vector3d shift = p.with.gnss[j].v_eb_n_mps - p.clean.gnss[j].v_eb_n_mps;
    EXPECT_NEAR((shift + s.a_n * tau).norm(), 0.0, 2e-5) << t;
    ++checked;
  }
  EXPECT_GT(checked, 50);
  EXPECT_EQ(p.with.gnss[0].t_s, 0.0);  // tags unchanged
}

TEST(Effects, LeverArmAddsRotationTermAndOffset) {
  const Eigen::Vector3d l(1.0, -0.5, -0.3);  // forward, left, up (FRD)
  ScenarioConfig c = base_config();
  const Dataset clean = simulate(c);
  c.injected.lever_arm_b_m = l;
  const Dataset with = simulate(c);
  const ScenarioPlan plan = plan_scenario(c);
  ImuSynthesizer synth(plan.trajectory, c.earth, c.imu_rate_hz, c.substeps);
  synth.run(plan.num_imu_steps);
  int turning = 0;
  for (std::size_t j = 0; j < with.gnss.size(); ++j) {
    const TrueState s = synth.state_at(with.gnss[j].t_s);
    const Eigen::Vector3d omega_eb_b =
        s.omega_ib_b - s.C_b_n.transpose() * c.earth.omega_ie_n(s.lat_rad);
    const Eigen::Vector3d expected_dv = s.C_b_n * omega_eb_b.cross(l);
    const Eigen::Vector3d dv = with.gnss[j].v_eb_n_mps - clean.gnss[j].v_eb_n_mps;
    EXPECT_NEAR((dv - expected_dv).norm(), 0.0, 1e-5);
    // position offset = C_b_n l in ENU
    const GnssSample& a = with.gnss[j];
    const GnssSample& b = clean.gnss[j];
    const Eigen::Vector3d d_enu(
        (a.lon_rad - b.lon_rad) * (c.earth.prime_vertical_radius_m(b.lat_rad) + b.h_m) *
            std::cos(b.lat_rad),
        (a.lat_rad - b.lat_rad) * (c.earth.meridian_radius_m(b.lat_rad) + b.h_m), a.h_m - b.h_m);
    EXPECT_NEAR((d_enu - s.C_b_n * l).norm(), 0.0, 1e-6);
    if (std::fabs(s.omega_nb_b.z()) > 0.1) {
      EXPECT_GT(expected_dv.norm(), 0.05);
      ++turning;
    }
  }
  EXPECT_GT(turning, 50);
}

// ----- seeds -------------------------------------------------------------------------------------

TEST(Seeds, SameSeedGivesByteIdenticalDatasetDifferentSeedDifferentNoise) {
  ScenarioConfig c = base_config();
  c.noise = noise_grade("mems");
  c.noise.gm_gyro_sigma_deg_h = 1.0;
  c.noise.gm_accel_sigma_mps2 = 1e-3;
  c.seed = 7;
  const fs::path dir = test::fresh_dir("seed-test");
  write_dataset(dir / "a", simulate(c));
  write_dataset(dir / "b", simulate(c));
  c.seed = 8;
  write_dataset(dir / "c", simulate(c));
  for (const char* f : {"imu.csv", "gnss.csv", "truth.csv", "meta.json"})
    EXPECT_EQ(test::read_file(dir / "a" / f), test::read_file(dir / "b" / f)) << f;
  EXPECT_NE(test::read_file(dir / "a" / "imu.csv"), test::read_file(dir / "c" / "imu.csv"));
  EXPECT_NE(test::read_file(dir / "a" / "gnss.csv"), test::read_file(dir / "c" / "gnss.csv"));
  EXPECT_EQ(test::read_file(dir / "a" / "truth.csv"), test::read_file(dir / "c" / "truth.csv"));
  // The written dataset loads back to the same numbers.
  const Dataset back = load_dataset(dir / "a");
  c.seed = 7;
  const Dataset again = simulate(c);
  ASSERT_EQ(back.imu.size(), again.imu.size());
  EXPECT_EQ(back.imu[1234].dv_b_mps, again.imu[1234].dv_b_mps);
  EXPECT_EQ(back.imu[1234].dtheta_b_rad, again.imu[1234].dtheta_b_rad);
  fs::remove_all(dir);
}

TEST(Seeds, NoiseHasTheGradesLevels) {
  ScenarioConfig c = base_config();
  c.noise = noise_grade("mems");
  const Dataset clean = simulate(base_config());
  const Dataset noisy = simulate(c);
  double s2 = 0;
  for (std::size_t k = 0; k < clean.imu.size(); ++k)
    s2 += std::pow(noisy.imu[k].dtheta_b_rad.x() - clean.imu[k].dtheta_b_rad.x(), 2);
  const double sigma = std::sqrt(s2 / clean.imu.size());
  const double expected = 0.2 * kDegToRad / 60.0 * std::sqrt(0.01);
  EXPECT_NEAR(sigma / expected, 1.0, 0.05);
  ASSERT_TRUE(noisy.meta.noise.has_value());
  EXPECT_EQ(noisy.meta.noise->arw_deg_rth, 0.2);
  EXPECT_FALSE(simulate(c, false).meta.noise.has_value());
  EXPECT_FALSE(simulate(c, false).meta.injected.has_value());
}

// ----- presets and bad inputs -------------------------------------------------------------------

TEST(Presets, AllPresetsPlanAndPaperMatchesTable3) {
  for (const std::string& name : preset_names()) {
    const ScenarioConfig c = preset_scenario(name);
    const ScenarioPlan p = plan_scenario(c);
    EXPECT_GT(p.flight_s, 0) << name;
    // to_json -> parse gives the same plan
    const ScenarioConfig back = parse_scenario(scenario_to_json(c), "roundtrip");
    EXPECT_EQ(plan_scenario(back).num_imu_steps, p.num_imu_steps) << name;
  }
  const ScenarioConfig paper = preset_scenario("paper");
  EXPECT_EQ(paper.imu_rate_hz, 100.0);
  EXPECT_EQ(paper.earth.ellipsoid.a_m, 6378245.0);
  EXPECT_EQ(paper.earth.omega_ie_rad_s, 7.292115147e-5);
  EXPECT_NEAR(paper.earth.normal_gravity_mps2(paper.initial.lat_rad, paper.initial.h_m), 9.801,
              1e-12);
  EXPECT_EQ(paper.align_s, 600.0);
  EXPECT_NEAR(get_effect(paper.injected, "accel_bias_x"), -2 * kSigmaAccelMps2, 1e-18);
  EXPECT_NEAR(get_effect(paper.injected, "accel_bias_y"), 1.5 * kSigmaAccelMps2, 1e-18);
  EXPECT_NEAR(get_effect(paper.injected, "gyro_bias_x"), 2 * kSigmaGyroRadS, 1e-22);
  EXPECT_NEAR(get_effect(paper.injected, "gyro_bias_y"), -1.5 * kSigmaGyroRadS, 1e-22);
  EXPECT_GE(plan_scenario(preset_scenario("rich")).flight_s, 2400.0);
}

TEST(BadInput, EachGetsAClearError) {
  EXPECT_THROW(preset_scenario("nope"), std::invalid_argument);
  auto has = [](const std::string& msg, const std::string& part) {
    EXPECT_NE(msg.find(part), std::string::npos) << "'" << part << "' not in: " << msg;
  };
  json j = base_json();
  j["bogus"] = 1;
  has(expect_invalid(j),
      "bad.json: bogus: unknown key (valid keys: name, description, comment, imu_rate_hz, ");
  j = base_json();
  j["segments"][2]["bank"] = 10;
  has(expect_invalid(j),
      "bad.json: segments[2].bank: unknown key (valid keys: type, turn_deg, direction, bank_deg, "
      "rate_deg_s, ramp_s, comment)");
  j = base_json();
  j["segments"][1]["type"] = "warp";
  has(expect_invalid(j),
      "bad.json: segments[1].type: expected one of \"static\", \"straight\", \"speed\", \"turn\", "
      "\"loiter\", \"s_turns\", \"climb\", \"descend\", \"takeoff\", found a string \"warp\"");
  j = base_json();
  j["injected"] = {{"accel_bais_x", 1e-3}};
  has(expect_invalid(j), "bad.json: injected.accel_bais_x: unknown effect name 'accel_bais_x'");
  j = base_json();
  j["segments"].push_back({{"type", "straight"}, {"duration_s", -3}});
  has(expect_invalid(j), "bad.json: segments[3]: straight segment: duration_s must be > 0, got -3");
  j = base_json();
  j["segments"][2] = {{"type", "turn"}, {"turn_deg", 90}, {"bank_deg", 75}};
  has(expect_invalid(j),
      "bad.json: segments[2]: turn segment: bank_deg must be in (0, 60] deg, got 75");
  j = base_json();
  j["gnss_rate_hz"] = 30;
  has(expect_invalid(j), "does not divide");
  j = base_json();
  j["align_s"] = 0;
  has(expect_invalid(j), "align_s must be > 0");
  j = base_json();
  j["flight_s"] = -10;
  has(expect_invalid(j), "flight_s must be > 0");
  j = base_json();
  j["noise"] = {{"grade", "consumer"}};
  has(expect_invalid(j), "bad.json: noise.grade: unknown noise grade 'consumer'");
  j = base_json();
  j["segments"][0]["dh_m"] = "ten";
  has(expect_invalid(j),
      "bad.json: segments[0].dh_m: expected a finite number, found a string \"ten\"");
}

// The message of the std::invalid_argument that loading a scenario file with `text` throws, or
// "(accepted)"; `path` receives the file's name.
std::string file_error(const std::string& text, std::string& path) {
  const fs::path file =
      fs::temp_directory_path() / ("insid_scenario_" + std::to_string(::getpid()) + ".json");
  path = file.string();
  std::ofstream(file) << text;
  std::string error = "(accepted)";
  try {
    load_scenario_file(file);
  } catch (const std::invalid_argument& e) {
    error = e.what();
  }
  fs::remove(file);
  return error;
}

// The one typed reader's wording (base/json_object.h) for each kind of fault of a scenario file:
// the file, the field's path, what was expected and what was found.
TEST(BadInput, ScenarioFileFaultsAreNamedWithTheFieldPath) {
  std::string path;
  const std::string segments = R"("segments": [{"type": "straight", "duration_s": 10}])";
  // GIVEN a good file THEN it loads
  EXPECT_EQ(file_error(R"({"initial": {"lat_deg": 40, "lon_deg": 116}, )" + segments + "}", path),
            "(accepted)");
  // an unknown key, with the valid ones
  EXPECT_EQ(
      file_error(R"({"initial": {"lat_deg": 40, "lon_deg": 116, "alt_m": 5}, )" + segments + "}",
                 path),
      path +
          ": initial.alt_m: unknown key (valid keys: lat_deg, lon_deg, h_m, roll_deg, "
          "pitch_deg, yaw_deg, comment)");
  // a missing key
  EXPECT_EQ(file_error(R"({"initial": {"lat_deg": 40}, )" + segments + "}", path),
            path + ": initial.lon_deg: missing, expected a finite number");
  // a wrong type
  EXPECT_EQ(file_error(R"({"initial": {"lat_deg": 40, "lon_deg": 116},
                            "segments": [{"type": "straight", "duration_s": [10]}]})",
                       path),
            path + ": segments[0].duration_s: expected a finite number, found an array [10]");
  // a key given twice (refused by the strict parser, in the same wording)
  EXPECT_EQ(
      file_error(R"({"initial": {"lat_deg": 40, "lon_deg": 116, "lat_deg": 41}, )" + segments + "}",
                 path),
      path +
          ": initial.lat_deg: key given twice in one object (JSON objects must not repeat "
          "a key)");
}

TEST(BadInput, UnwritableOutputLeavesNothingBehind) {
  const fs::path base = test::fresh_dir("unwritable");
  fs::create_directories(base);
  { std::ofstream(base / "file") << "x"; }  // a regular file where a directory should go
  const Dataset ds = simulate(base_config());
  EXPECT_THROW(write_dataset(base / "file" / "out", ds), DatasetError);
  std::size_t entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(base)) ++entries;
  EXPECT_EQ(entries, 1u);
  fs::remove_all(base);
}

}  // namespace
}  // namespace insid::scenarios
