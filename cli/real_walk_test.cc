// The real pipeline on the shared MEMS walk (../shared/data/rtklib-walk), end to end
// through the insid binary as scripts/real_report.sh runs it: import with the documented mounting
// and the measured static window, identify with one method (LM on the W = 20 s windowed fitness,
// level+heading), then navigate with and without the estimate. Skips (with the reason) where the
// shared data are absent.
#include <unistd.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_support/files.h"
#include "test_support/process.h"

namespace {
namespace fs = std::filesystem;

namespace test = insid::test;
using insid::test::insid;
using insid::test::Outcome;

// Mean angular rate (deg/s, body axes) over the dataset's first `span_s` seconds of IMU rows:
// sum of the increments over their time (the first row, whose interval is unknown, left out).
std::array<double, 3> mean_rate_deg_s(const fs::path& imu_csv, double span_s) {
  std::ifstream in(imu_csv);
  std::string line;
  std::getline(in, line);  // header: t_s,dtheta_x_rad,dtheta_y_rad,dtheta_z_rad,dv_...
  std::array<double, 3> sum{0.0, 0.0, 0.0};
  double t_first = NAN, t_prev = NAN, t_last = NAN;
  while (std::getline(in, line)) {
    std::istringstream row(line);
    std::string cell;
    double v[4];
    for (double& x : v) {
      std::getline(row, cell, ',');
      x = std::stod(cell);
    }
    if (std::isnan(t_first)) {
      t_first = t_prev = v[0];
      continue;
    }
    if (v[0] > t_first + span_s) break;
    for (int i = 0; i < 3; ++i) sum[static_cast<std::size_t>(i)] += v[i + 1];
    t_last = v[0];
  }
  for (double& x : sum) x = x / (t_last - t_prev) * 180.0 / M_PI;
  return sum;
}

// MEMS box as in scripts/real_report.sh: sigma 0.1 deg/s, 10 mg; gyro z [-8, 8] sigma.
const char* kEstimate =
    " --estimate gyro_bias_x:0.0017453292519943296 --estimate gyro_bias_y:0.0017453292519943296"
    " --estimate gyro_bias_z:0.0017453292519943296:-8:8 --estimate accel_bias_x:0.0980665"
    " --estimate accel_bias_y:0.0980665";

// Import + LM identification + compensated navigation. The estimate must explain the walk's
// pure-INS drift: the one-run (W = 0) rms horizontal velocity error against the RTK velocity
// with the estimate compensated at most a quarter of the uncompensated one. Measured on this
// machine: 19.8 -> 1.63 m/s (12x); with the scalar compensation's gyro bias sign flipped
// (model/sensor_errors.cc) the compensated run gives 31.7 m/s and the check fails. Then the
// gyro x/y biases against the first 3 s on the pad (below).
// Every reported sd is finite and positive (the uncertainty runs on real data, where the noise
// levels are estimated from the static window).
TEST(RealWalk, ImportIdentifyCutsThePureInsErrorFourfoldAndMatchesThePadGyros) {
  const fs::path walk = fs::path(INSID_SHARED_DATA) / "rtklib-walk";
  if (!fs::exists(walk / "imu_1730_sf.csv") || !fs::exists(walk / "gnss_1730_sf.pos"))
    GTEST_SKIP() << "../shared/data/rtklib-walk is absent (tests that need the shared real data "
                    "skip outside CI)";
  const fs::path root = test::fresh_dir("real-walk");
  fs::create_directories(root);
  const fs::path data = root / "walk";

  // --align-s 9: the static window up to the last quiet gyro block (scripts/real_report.py
  // --static-end; the default window ends while the walker turns on the spot).
  Outcome o = insid("import csv --imu " + (walk / "imu_1730_sf.csv").string() +
                    " --columns t,ax,ay,az,gx,gy,gz,-,-,-,- --units s,g-local,rad/s --gnss " +
                    (walk / "gnss_1730_sf.pos").string() +
                    " --mounting-rpy-deg 180,0,-90 --align-s 9 --out " + data.string());
  ASSERT_EQ(o.status, 0) << o.output;

  const std::string common = " --data " + data.string() + " --initial-attitude level+heading";
  o = insid("identify" + common + kEstimate +
            " --algo lm --window-s 20 --no-reference-optimum --uncertainty-replicas 20 --threads 1"
            " --out " +
            (root / "lm.json").string());
  ASSERT_EQ(o.status, 0) << o.output;
  const nlohmann::json result = test::read_json(root / "lm.json");
  ASSERT_EQ(result.at("parameters").size(), 5u);
  // --grade auto reads the imported walk's static window (no noise block in its meta.json):
  // a MEMS unit, the rule and its numbers recorded.
  const nlohmann::json& grade = result.at("grade_choice");
  EXPECT_EQ(grade.at("grade"), "mems") << grade.dump();
  EXPECT_EQ(grade.at("source"), "static window") << grade.dump();
  EXPECT_GT(grade.at("arw_deg_rth").get<double>(), 0.01) << grade.dump();
  EXPECT_EQ(result.at("window_s_source"), "--window-s");
  // Without --window-s, MEMS data get the default window (10 s), said so.
  o = insid("identify" + common +
            " --algo pso --iterations 1 --no-reference-optimum --uncertainty-replicas 0"
            " --threads 1 --out " +
            (root / "auto.json").string());
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_NE(o.output.find("grade mems (auto: static window"), std::string::npos) << o.output;
  const nlohmann::json automatic = test::read_json(root / "auto.json");
  EXPECT_EQ(automatic.at("window_s").get<double>(), 10.0);
  EXPECT_EQ(automatic.at("window_s_source"), "default for mems data");
  std::string compensate;
  for (const auto& p : result.at("parameters")) {
    const double estimate = p.at("estimate").get<double>();
    ASSERT_TRUE(std::isfinite(estimate)) << p.dump();
    ASSERT_TRUE(p.at("sd").is_number()) << p.dump();
    EXPECT_GT(p.at("sd").get<double>(), 0.0) << p.dump();
    char item[128];
    std::snprintf(item, sizeof item, " --compensate %s=%.17g",
                  p.at("name").get<std::string>().c_str(), estimate);
    compensate += item;
  }

  o = insid("navigate" + common + " --summary " + (root / "none.json").string());
  ASSERT_EQ(o.status, 0) << o.output;
  o = insid("navigate" + common + compensate + " --summary " + (root / "comp.json").string());
  ASSERT_EQ(o.status, 0) << o.output;
  const double rms_none = test::read_json(root / "none.json").at("rms_dvh_mps").get<double>();
  const double rms_comp = test::read_json(root / "comp.json").at("rms_dvh_mps").get<double>();
  std::cout << "[ walk ] pure-INS rms |dv_h|: uncompensated " << rms_none << " m/s, with the LM "
            << "estimate (W = 20 s) " << rms_comp << " m/s (" << rms_none / rms_comp << "x)\n";
  EXPECT_LT(rms_comp, 0.25 * rms_none);

  // The independent check of the report: on the pad the gyros read bias + Earth rate (<= 0.004
  // deg/s); the first 3 s of the walk are still (gyro scatter 0.01-0.05 deg/s, report). The
  // horizontal gyro biases found from GNSS must match that mean within 0.05 deg/s (measured
  // 0.025 and 0.008 deg/s; the spread between methods and windows in results/real is
  // 0.01-0.04 deg/s). Checked red: with the batched kernel's gyro bias compensation sign
  // flipped (kernel/batch_fitness.cc) LM finds -0.175 / 0.103 deg/s and the compensated run is
  // worse than the uncompensated one (32 m/s), so all three checks fail.
  const std::array<double, 3> pad = mean_rate_deg_s(data / "imu.csv", 3.0);
  double est_deg_s[2] = {0.0, 0.0};
  for (const auto& p : result.at("parameters")) {
    const std::string name = p.at("name").get<std::string>();
    if (name == "gyro_bias_x") est_deg_s[0] = p.at("estimate").get<double>() * 180.0 / M_PI;
    if (name == "gyro_bias_y") est_deg_s[1] = p.at("estimate").get<double>() * 180.0 / M_PI;
  }
  std::cout << "[ walk ] gyro x/y bias (deg/s): LM " << est_deg_s[0] << ", " << est_deg_s[1]
            << "; pad mean " << pad[0] << ", " << pad[1] << "\n";
  EXPECT_NEAR(est_deg_s[0], pad[0], 0.05);
  EXPECT_NEAR(est_deg_s[1], pad[1], 0.05);
  fs::remove_all(root);
}

// Effects hidden in the real walk (differential injection; the whole table:
// scripts/real_injection.py, results/real/injection.md): the background keeps all the walk's
// unknown effects, the injected part is known. A copy of the raw IMU log with its clock shifted
// by +0.25 s (the IMU stamps late: insid's gnss_latency moves by -0.25 s), and one with
// +0.1 deg/s on the sensor x gyro (body y = -sensor x: gyro_bias_y moves by -0.1 deg/s), go
// through the same import and LM on the W = 10 s windowed fitness as the plain log; the
// difference of the estimates must equal the injected value within 3 sd + 20 % (sd: both runs'
// combined). The sd must also be below half the injected size: the walk has to pin it down.
// Measured (2-core Zen 4): latency difference -0.316 s, sd 0.052 (without the windowed
// fitness's window-start fix: -0.223 s, sd 0.015, also inside the bound, so this case is no red
// test of that fix: WindowGnssEffects is); gyro_bias_y -0.09998 deg/s, sd 0.034.
TEST(RealWalk, InjectedClockShiftAndGyroBiasAreRecoveredBySize) {
  const fs::path walk = fs::path(INSID_SHARED_DATA) / "rtklib-walk";
  if (!fs::exists(walk / "imu_1730_sf.csv") || !fs::exists(walk / "gnss_1730_sf.pos"))
    GTEST_SKIP() << "../shared/data/rtklib-walk is absent (tests that need the shared real data "
                    "skip outside CI)";
  const fs::path root = test::fresh_dir("real-injection");
  fs::create_directories(root);
  // column 0: GPST seconds; column 4: the sensor x gyro (rad/s)
  auto variant = [&](const std::string& name, int column, double add) {
    std::ifstream in(walk / "imu_1730_sf.csv");
    std::ofstream out(root / (name + ".csv"));
    for (std::string line; std::getline(in, line);) {
      std::vector<std::string> cells;
      std::istringstream row(line);
      for (std::string cell; std::getline(row, cell, ',');) cells.push_back(cell);
      char value[64];
      std::snprintf(value, sizeof value, "%.9f",
                    std::stod(cells[static_cast<std::size_t>(column)]) + add);
      cells[static_cast<std::size_t>(column)] = value;
      for (std::size_t i = 0; i < cells.size(); ++i) out << (i ? "," : "") << cells[i];
      out << "\n";
    }
    return root / (name + ".csv");
  };
  auto import = [&](const fs::path& imu, const std::string& name) {
    const Outcome o =
        insid("import csv --imu " + imu.string() +
              " --columns t,ax,ay,az,gx,gy,gz,-,-,-,- --units s,g-local,rad/s"
              " --gnss " +
              (walk / "gnss_1730_sf.pos").string() +
              " --mounting-rpy-deg 180,0,-90 --align-s 9 --out " + (root / name).string());
    EXPECT_EQ(o.status, 0) << o.output;
    return root / name;
  };
  // (estimate, sd) of `effect` from LM on W = 10 s.
  auto identify = [&](const fs::path& data, const std::string& extra, const std::string& effect) {
    const fs::path out = root / (data.filename().string() + "-" + effect + ".json");
    const Outcome o = insid("identify --data " + data.string() + kEstimate + extra +
                            " --initial-attitude level+heading --algo lm --window-s 10"
                            " --no-reference-optimum --uncertainty-replicas 40 --threads 1"
                            " --quiet --out " +
                            out.string());
    EXPECT_EQ(o.status, 0) << o.output;
    const nlohmann::json result = test::read_json(out);
    for (const auto& p : result.at("parameters"))
      if (p.at("name").get<std::string>() == effect)
        return std::pair<double, double>(p.at("estimate").get<double>(), p.at("sd").get<double>());
    ADD_FAILURE() << effect << " not in " << out;
    return std::pair<double, double>(NAN, NAN);
  };
  const fs::path plain = import(walk / "imu_1730_sf.csv", "plain");
  struct Case {
    std::string name, extra, effect;
    int column;
    double add, expected;
  };
  const double bias_rad_s = 0.1 * M_PI / 180.0;
  for (const Case& c :
       {Case{"clock", " --estimate gnss_latency:0.1:-4:4", "gnss_latency", 0, 0.25, -0.25},
        Case{"gyro", "", "gyro_bias_y", 4, bias_rad_s, -bias_rad_s}}) {
    const fs::path injected = import(variant(c.name, c.column, c.add), c.name);
    const auto [e0, sd0] = identify(plain, c.extra, c.effect);
    const auto [e1, sd1] = identify(injected, c.extra, c.effect);
    const double difference = e1 - e0, sd = std::hypot(sd0, sd1);
    std::cout << "[ walk injection ] " << c.effect << ": plain " << e0 << ", injected " << e1
              << ", difference " << difference << " (injected " << c.expected << "), sd " << sd
              << "\n";
    EXPECT_LE(std::abs(difference - c.expected), 3.0 * sd + 0.2 * std::abs(c.expected)) << c.effect;
    EXPECT_LT(sd, 0.5 * std::abs(c.expected)) << c.effect << ": the walk must pin it down";
  }
  if (!::testing::Test::HasFailure()) fs::remove_all(root);  // kept for a look on failure
}

}  // namespace
