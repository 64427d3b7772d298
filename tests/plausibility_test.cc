// Implausible data said in plain words (data/plausibility.h): on simulated flights
// with each mistake of the audit made on purpose (specific force in g declared as m/s^2, gyros
// scaled by 1/57.3 or 57.3, east and north velocities swapped, negated, in km/h, an IMU clock
// 18 s off) the matching check fires and names the likely cause; on the correct flights (nav
// and MEMS grade) nothing fires.
#include "data/plausibility.h"

#include <string>

#include <gtest/gtest.h>

#include "model/units.h"
#include "scenarios/noise.h"
#include "scenarios/scenario.h"

namespace insid {
namespace {

Dataset flight(const std::string& preset, const std::string& grade, double align_s,
               double flight_s) {
  scenarios::ScenarioConfig cfg = scenarios::preset_scenario(preset);
  cfg.align_s = align_s;
  cfg.flight_s = flight_s;
  cfg.noise = scenarios::noise_grade(grade);
  cfg.seed = 7;
  return scenarios::simulate(cfg);
}

std::string checks_of(const PlausibilityReport& r) {
  std::string s;
  for (const PlausibilityFinding& f : r.findings) s += f.check + " (" + f.text() + ") ";
  return s.empty() ? "(none)" : s;
}

const PlausibilityFinding* find(const PlausibilityReport& r, const std::string& check) {
  for (const PlausibilityFinding& f : r.findings)
    if (f.check == check) return &f;
  return nullptr;
}

void expect_cause(const PlausibilityReport& r, const std::string& check, const std::string& cause) {
  const PlausibilityFinding* f = find(r, check);
  ASSERT_NE(f, nullptr) << check << " did not fire; fired: " << checks_of(r);
  EXPECT_NE(f->likely_cause.find(cause), std::string::npos) << f->text();
  EXPECT_FALSE(f->expected.empty());
  EXPECT_FALSE(f->found.empty());
}

class Plausibility : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    nav_ = new Dataset(flight("rich", "nav", 60.0, 300.0));
    mems_ = new Dataset(flight("multicopter", "mems", 30.0, 300.0));
  }
  static void TearDownTestSuite() {
    delete nav_;
    delete mems_;
  }
  static Dataset* nav_;
  static Dataset* mems_;
};
Dataset* Plausibility::nav_ = nullptr;
Dataset* Plausibility::mems_ = nullptr;

TEST_F(Plausibility, TheCorrectFlightsRaiseNothing) {
  for (const Dataset* d : {nav_, mems_}) {
    const PlausibilityReport r = check_plausibility(*d);
    EXPECT_TRUE(r.findings.empty()) << checks_of(r);
    EXPECT_FALSE(r.refused());
  }
  // Every check ran on the nav flight (a static window that sees the Earth rate, turns,
  // horizontal and vertical motion, accelerations for the clock).
  EXPECT_TRUE(check_plausibility(*nav_).not_checked.empty())
      << check_plausibility(*nav_).to_json().dump(2);
}

TEST_F(Plausibility, SpecificForceInGDeclaredAsMetresPerSecondSquaredIsRefused) {
  Dataset d = *mems_;
  for (ImuSample& s : d.imu) s.dv_b_mps /= kStandardGravity_mps2;
  const PlausibilityReport r = check_plausibility(d);
  expect_cause(r, "static_gravity", "look like g, not m/s^2");
  EXPECT_TRUE(r.refused());
}

TEST_F(Plausibility, AnUpsideDownMountingIsNamed) {
  for (const Dataset* base : {nav_, mems_}) {
    Dataset d = *base;  // mounted with a roll of 180 deg too many: y and z negated
    for (ImuSample& s : d.imu) {
      s.dv_b_mps.tail<2>() *= -1.0;
      s.dtheta_b_rad.tail<2>() *= -1.0;
    }
    const PlausibilityReport r = check_plausibility(d);
    expect_cause(r, "static_attitude", "upside down at rest");
    EXPECT_FALSE(r.refused());
  }
}

TEST_F(Plausibility, GyroUnitMixUpsAreNamed) {
  Dataset down = *nav_;  // rates in rad/s declared as deg/s: the Earth rate 0.26 deg/h
  for (ImuSample& s : down.imu) s.dtheta_b_rad /= 57.29577951308232;
  const PlausibilityReport r = check_plausibility(down);
  expect_cause(r, "static_earth_rate", "rad/s read as deg/s");
  expect_cause(r, "gyro_turn_rate", "in rad/s, read as deg/s");
  Dataset up = *mems_;  // rates in deg/s declared as rad/s: 57.3 times too large
  for (ImuSample& s : up.imu) s.dtheta_b_rad *= 57.29577951308232;
  expect_cause(check_plausibility(up), "gyro_turn_rate", "in deg/s, read as rad/s");
}

TEST_F(Plausibility, GnssVelocityAxesSignsAndUnitsAreNamed) {
  Dataset swapped = *mems_, negated = *mems_, kmh = *mems_;
  for (GnssSample& g : swapped.gnss) std::swap(g.v_eb_n_mps.x(), g.v_eb_n_mps.y());
  for (GnssSample& g : negated.gnss) g.v_eb_n_mps.head<2>() *= -1.0;
  for (GnssSample& g : kmh.gnss) g.v_eb_n_mps *= 3.6;
  expect_cause(check_plausibility(swapped), "gnss_velocity", "swapped");
  expect_cause(check_plausibility(negated), "gnss_velocity", "negated");
  expect_cause(check_plausibility(kmh), "gnss_velocity", "in km/h, read as m/s");
  Dataset down = *nav_;  // a vertical velocity positive down
  for (GnssSample& g : down.gnss) g.v_eb_n_mps.z() *= -1.0;
  expect_cause(check_plausibility(down), "gnss_velocity", "down, not up");
}

TEST_F(Plausibility, AnImuClockEighteenSecondsOffIsNamed) {
  for (const Dataset* base : {nav_, mems_}) {
    Dataset d = *base;
    for (ImuSample& s : d.imu) s.t_s += 18.0;
    const PlausibilityReport r = check_plausibility(d);
    expect_cause(r, "imu_gnss_clock", "leap seconds");
  }
}

}  // namespace
}  // namespace insid
