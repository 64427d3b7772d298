// `insid import ardupilot --imu all` and `insid cross-imu` through the insid binary: usage errors
// (no data needed), then the shared ArduPilot log (../shared/data/ardupilot-copter/log171.bin,
// read in place), whose three IMUs give a known truth: IMU2 - IMU3 gyro x near 0 on the ground
// before the motors start, +0.4..+0.7 deg/s in flight (README of the shared data). Skips where
// the log is absent.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support/files.h"
#include "test_support/process.h"

namespace {
namespace fs = std::filesystem;

namespace test = insid::test;
using insid::test::insid;
using insid::test::Outcome;

const fs::path kLog = fs::path(INSID_SHARED_DATA) / "ardupilot-copter" / "log171.bin";
constexpr const char* kNoLog =
    "../shared/data/ardupilot-copter/log171.bin is absent (tests that need the shared real data "
    "skip without it)";

// The options are checked before any file is read (exit 2) and nothing is written.
TEST(CrossImuCli, UsageErrors) {
  test::TempDir tmp;
  ASSERT_FALSE(tmp.path.empty());
  const std::string a = (tmp.path / "a").string(), b = (tmp.path / "b").string();
  const std::string out = " --out " + (tmp.path / "x.json").string();
  Outcome o = insid("cross-imu --data " + a + out);
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_TRUE(test::contains(o.output, "give at least two datasets")) << o.output;
  o = insid("cross-imu --data " + a + " --data " + b + " --result r.json" + out);
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_TRUE(test::contains(o.output, "--result: 1 results for 2 datasets")) << o.output;
  o = insid("cross-imu --data " + a + " --data " + b + " --t-start 9 --t-end 3" + out);
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_TRUE(test::contains(o.output, "--t-start 9 must be before --t-end 3")) << o.output;
  o = insid("cross-imu --data " + a + " --data " + b + " --clock gps" + out);
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_TRUE(test::contains(o.output, "--clock 'gps': must be dataset or boot")) << o.output;
  o = insid("cross-imu --data " + a + " --data " + a + out);
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_TRUE(test::contains(o.output, "is given twice")) << o.output;
  o = insid("cross-imu --data " + a + " --data " + b + " --block-s 0" + out);
  EXPECT_EQ(o.status, 2) << o.output;
  o = insid("import ardupilot " + (tmp.path / "none.bin").string() + " --imu IMU9 --out " +
            (tmp.path / "ds").string());
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_TRUE(test::contains(o.output, "or all (every one the log has")) << o.output;
  o = insid("import ulog " + (tmp.path / "none.ulg").string() +
            " --imu-instance all --imu-topic sensor_combined --out " + (tmp.path / "ds").string());
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_TRUE(test::contains(o.output, "--imu-instance all imports every instance of vehicle_imu"))
      << o.output;
  o = insid("import ulog " + (tmp.path / "none.ulg").string() + " --imu-instance 1x --out " +
            (tmp.path / "ds").string());
  EXPECT_EQ(o.status, 2) << o.output;
  EXPECT_TRUE(
      test::contains(o.output, "--imu-instance '1x': must be a whole number in 0-255, or all"))
      << o.output;
  EXPECT_FALSE(fs::exists(tmp.path / "x.json"));
  EXPECT_FALSE(fs::exists(tmp.path / "ds"));
}

// The shared PX4 logs with several vehicle_imu instances log them at 2 Hz: --imu-instance all
// names the instance that fails, and writes nothing.
TEST(CrossImuCli, UlogEveryInstanceNamesTheOneThatFails) {
  const fs::path ulg = fs::path(INSID_SHARED_DATA) / "px4-ulog" / "sample_log_small.ulg";
  if (!fs::exists(ulg)) GTEST_SKIP() << ulg << " is absent";
  test::TempDir tmp;
  ASSERT_FALSE(tmp.path.empty());
  const Outcome o = insid("import ulog " + ulg.string() + " --imu-instance all --align-s 1 --out " +
                          (tmp.path / "px4").string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_TRUE(test::contains(o.output,
                             "--imu-instance all: vehicle_imu instance 0 failed, nothing written"))
      << o.output;
  EXPECT_FALSE(fs::exists(tmp.path / "px4"));
}

// Every IMU of the log in one command; then the cross-IMU check on the boot clock: in flight
// (85-215 s) IMU2 - IMU3 gyro x is positive, 0.3-0.8 deg/s; on the ground before the motors
// (75-82.5 s) it is near 0; the segments show the jump at motor start (~83 s).
TEST(CrossImuCli, RealLogAllImusAndTheirDifferences) {
  if (!fs::exists(kLog)) GTEST_SKIP() << kNoLog;
  test::TempDir tmp;
  ASSERT_FALSE(tmp.path.empty());
  // The whole log has a 2 s logging gap: the first IMU fails, is named, and nothing is written.
  const fs::path refused = tmp.path / "refused";
  Outcome o = insid("import ardupilot " + kLog.string() + " --imu all --out " + refused.string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_TRUE(test::contains(o.output, "--imu all: IMU failed, nothing written")) << o.output;
  EXPECT_TRUE(test::contains(o.output, "logging gap of 2.022 s")) << o.output;
  EXPECT_FALSE(fs::exists(refused));

  const fs::path ds = tmp.path / "copter";
  o = insid("import ardupilot " + kLog.string() +
            " --imu all --t-start 74.7 --t-end 215 "
            "--out " +
            ds.string());
  ASSERT_EQ(o.status, 0) << o.output;
  for (const char* name : {"IMU", "IMU2", "IMU3"}) {
    ASSERT_TRUE(fs::exists(ds / name / "imu.csv")) << name;
    EXPECT_EQ(test::read_json(ds / name / "provenance.json").at("options").at("imu"), name);
  }
  // Same options and window: the same IMU instants.
  EXPECT_EQ(test::read_json(ds / "IMU2" / "meta.json").at("align_s"),
            test::read_json(ds / "IMU3" / "meta.json").at("align_s"));

  const std::string data =
      " --data " + (ds / "IMU3").string() + " --data " + (ds / "IMU2").string() + " --clock boot";
  const fs::path flight = tmp.path / "flight.json";
  o = insid("cross-imu" + data + " --t-start 85 --t-end 215 --out " + flight.string());
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_TRUE(test::contains(o.output, "IMU2 - IMU3")) << o.output;
  const nlohmann::json f = test::read_json(flight);
  EXPECT_EQ(f.at("format"), "insid-cross-imu/1");
  const nlohmann::json& x = f.at("pairs").at(0).at("gyro").at("x");
  EXPECT_EQ(f.at("pairs").at(0).at("difference"), "IMU2 - IMU3");
  const double dx = x.at("gyro_bias_diff_deg_s").get<double>();
  const double se = x.at("se_deg_s").get<double>();
  EXPECT_GT(dx, 0.3) << dx;
  EXPECT_LT(dx, 0.8) << dx;
  EXPECT_GT(se, 0.0);
  EXPECT_LT(se, 0.1);

  const fs::path ground = tmp.path / "ground.json";
  o = insid("cross-imu" + data + " --t-start 75 --t-end 82.5 --out " + ground.string());
  ASSERT_EQ(o.status, 0) << o.output;
  const nlohmann::json g = test::read_json(ground);
  const double gx = g.at("pairs").at(0).at("gyro").at("x").at("gyro_bias_diff_deg_s").get<double>();
  EXPECT_LT(std::abs(gx), 0.1) << gx;
  // On the ground the rates are noise: no rate column enters.
  EXPECT_EQ(g.at("pairs").at(0).at("rate_columns_used"), nlohmann::json({false, false, false}));

  // The whole cut, 1 s segments: the last segment before 82.5 s near 0, the first after 84 s
  // above 0.3 deg/s.
  const fs::path all = tmp.path / "all.json";
  o = insid("cross-imu" + data + " --segment-s 1 --block-s 0.2 --out " + all.string());
  ASSERT_EQ(o.status, 0) << o.output;
  double before = NAN, after = NAN;
  const nlohmann::json whole = test::read_json(all);
  for (const nlohmann::json& s : whole.at("pairs").at(0).at("segments")) {
    const double t0 = s.at("t_s").at(0).get<double>();
    const double v = s.at("gyro_bias_diff_deg_s").at(0).get<double>();
    if (t0 < 82.5 && t0 >= 81.0) before = v;
    if (t0 >= 84.0 && std::isnan(after)) after = v;
  }
  EXPECT_LT(std::abs(before), 0.15) << before;
  EXPECT_GT(after, 0.3) << after;

  // With insid's own results (EKF-RTS per IMU): the comparison table, a verdict per pair-axis
  // (which one is insid's business, not this test's: the estimators change).
  std::string results;
  for (const char* name : {"IMU3", "IMU2"}) {
    const fs::path r = tmp.path / (std::string(name) + ".json");
    o = insid("identify --data " + (ds / name).string() +
              " --grade mems --initial-attitude level+heading --window-s 10 --estimate gyro_bias_x"
              " --estimate gyro_bias_y --estimate gyro_bias_z --estimate accel_bias_z --algo "
              "ekf-rts --no-reference-optimum --threads 1 --quiet --out " +
              r.string());
    ASSERT_EQ(o.status, 0) << o.output;
    results += " --result " + r.string();
  }
  const fs::path cmp = tmp.path / "cmp.json";
  o = insid("cross-imu" + data + results + " --t-start 85 --t-end 215 --out " + cmp.string());
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_TRUE(test::contains(o.output, "insid's estimated differences against the direct ones"))
      << o.output;
  const nlohmann::json c = test::read_json(cmp);
  ASSERT_EQ(c.at("comparison").size(), 3u);
  for (const nlohmann::json& row : c.at("comparison"))
    EXPECT_NE(row.at("verdict"), "not_compared") << row.dump();
  // A result that is not insid's is refused, naming the file.
  o = insid("cross-imu" + data + " --result " + flight.string() + " --result " + cmp.string() +
            " --out " + (tmp.path / "never.json").string());
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_TRUE(test::contains(o.output, "format: expected \"insid-identify/2\"")) << o.output;
  EXPECT_FALSE(fs::exists(tmp.path / "never.json"));

  // An input is never overwritten.
  o = insid("cross-imu" + data + " --out " + (ds / "IMU2" / "imu.csv").string());
  EXPECT_NE(o.status, 0) << o.output;
}

}  // namespace
