// Implausible data said in plain words on the shared real recordings
// (data/plausibility.h): their correct imports raise nothing; the audit's wrong imports of the
// walk are each named (specific force in g declared as m/s^2 refused; rates in rad/s declared as
// deg/s; an IMU clock 18 s off). Skips where ../shared/data is absent.

#include <filesystem>
#include <fstream>
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

nlohmann::json plausibility_of(const fs::path& dataset) {
  std::ifstream in(dataset / "provenance.json");
  return nlohmann::json::parse(in).at("plausibility");
}

class PlausibilityReal : public ::testing::Test {
 protected:
  void SetUp() override {
    shared_ = fs::path(INSID_SHARED_DATA);
    if (!fs::exists(shared_ / "rtklib-walk" / "imu_1730_sf.csv") ||
        !fs::exists(shared_ / "ardupilot-copter" / "log171.bin"))
      GTEST_SKIP() << "../shared/data is absent (tests that need the shared real recordings skip "
                      "outside CI)";
    root_ = test::fresh_dir("plausibility");
    fs::create_directories(root_);
  }
  void TearDown() override {
    if (!root_.empty()) fs::remove_all(root_);
  }
  std::string walk(const std::string& units, const std::string& extra, const fs::path& out) const {
    const fs::path w = shared_ / "rtklib-walk";
    return "import csv --imu " + (w / "imu_1730_sf.csv").string() +
           " --columns t,ax,ay,az,gx,gy,gz,-,-,-,- --units " + units + " --gnss " +
           (w / "gnss_1730_sf.pos").string() + " --mounting-rpy-deg 180,0,-90 --align-s 9 " +
           extra + " --out " + out.string();
  }
  fs::path shared_, root_;
};

TEST_F(PlausibilityReal, TheCorrectImportsRaiseNothing) {
  Outcome o = insid(walk("s,g-local,rad/s", "", root_ / "walk"));
  ASSERT_EQ(o.status, 0) << o.output;
  EXPECT_FALSE(test::contains(o.output, "implausible")) << o.output;
  EXPECT_TRUE(plausibility_of(root_ / "walk")["findings"].empty());
  for (const std::string imu : {"IMU", "IMU2", "IMU3"}) {
    const fs::path out = root_ / imu;
    o = insid("import ardupilot " + (shared_ / "ardupilot-copter" / "log171.bin").string() +
              " --imu " + imu + " --t-start 74.7 --t-end 215 --out " + out.string());
    ASSERT_EQ(o.status, 0) << o.output;
    EXPECT_FALSE(test::contains(o.output, "implausible")) << imu << "\n" << o.output;
    EXPECT_TRUE(plausibility_of(out)["findings"].empty()) << imu;
    // Before the work too: navigate says nothing either.
    o = insid("navigate --data " + out.string() + " --initial-attitude level+heading --summary " +
              (root_ / (imu + ".json")).string());
    ASSERT_EQ(o.status, 0) << o.output;
    EXPECT_FALSE(test::contains(o.output, "implausible")) << imu << "\n" << o.output;
  }
}

TEST_F(PlausibilityReal, TheAuditsWrongWalkImportsAreNamed) {
  // Specific force in g declared as m/s^2: refused, nothing written.
  Outcome o = insid(walk("s,m/s^2,rad/s", "", root_ / "g"));
  EXPECT_EQ(o.status, 1) << o.output;
  EXPECT_TRUE(test::contains(o.output, "the accelerations look like g, not m/s^2")) << o.output;
  EXPECT_FALSE(fs::exists(root_ / "g"));
  // Rates in rad/s declared as deg/s: imported, with the warning.
  o = insid(walk("s,g-local,deg/s", "", root_ / "deg"));
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_TRUE(test::contains(o.output, "the gyro rates look in rad/s, read as deg/s")) << o.output;
  // The IMU clock 18 s off (the leap seconds): imported, with the warning, and said again by
  // the commands that read it.
  o = insid(walk("s,g-local,rad/s", "--imu-time-offset-s 18", root_ / "clock"));
  EXPECT_EQ(o.status, 0) << o.output;
  EXPECT_TRUE(test::contains(o.output, "GPS-UTC leap seconds")) << o.output;
  const nlohmann::json findings = plausibility_of(root_ / "clock")["findings"];
  ASSERT_EQ(findings.size(), 1u) << findings.dump(2);
  EXPECT_EQ(findings[0]["check"], "imu_gnss_clock");
  // Said again before the work by a command that reads it (navigate then also refuses the
  // shifted static window, for its own reason).
  o = insid("navigate --data " + (root_ / "clock").string() +
            " --initial-attitude level+heading --summary " + (root_ / "clock.json").string());
  EXPECT_TRUE(test::contains(o.output, "insid navigate: implausible data")) << o.output;
  EXPECT_TRUE(test::contains(o.output, "GPS-UTC leap seconds")) << o.output;
}

}  // namespace
