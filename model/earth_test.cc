#include "model/earth.h"

#include <cmath>

#include <gtest/gtest.h>

#include "model/rotation.h"

namespace insid {
namespace {

TEST(Earth, Wgs84RadiiMatchPublishedValues) {
  const EarthModel earth = EarthModel::wgs84();
  // Equator: R_M = a (1 - e2) = 6335439.327 m, R_N = a. Pole: R_M = R_N = a / sqrt(1 - e2)
  // = 6399593.626 m (NIMA TR8350.2 / Groves, Principles of GNSS, INS and multisensor nav.).
  EXPECT_NEAR(earth.meridian_radius_m(0.0), 6335439.327, 1e-3);
  EXPECT_NEAR(earth.prime_vertical_radius_m(0.0), 6378137.0, 1e-6);
  EXPECT_NEAR(earth.meridian_radius_m(kPi / 2), 6399593.626, 1e-3);
  EXPECT_NEAR(earth.prime_vertical_radius_m(kPi / 2), 6399593.626, 1e-3);
  // 45 deg: R_N = 6388838.29 m, R_M = 6367381.82 m.
  EXPECT_NEAR(earth.prime_vertical_radius_m(kPi / 4), 6388838.290, 1e-2);
  EXPECT_NEAR(earth.meridian_radius_m(kPi / 4), 6367381.816, 1e-2);
}

TEST(Earth, NormalGravityMatchesPublishedValues) {
  const EarthModel earth = EarthModel::wgs84();
  EXPECT_NEAR(earth.normal_gravity_mps2(0.0, 0.0), 9.7803267714, 1e-10);
  // docs/design.md's series (the form used in Qin Yongyuan's "Inertial Navigation" and PSINS) has
  // 5.27094e-3 where the WGS-84 expansion of Somigliana's formula has 5.2790414e-3, so it
  // departs from the published WGS-84 normal gravity by up to 8.1e-5 m/s^2 (at the poles).
  // Published WGS-84 values (NIMA TR8350.2, table 4.1): pole 9.8321849378, 45 deg 9.8061992.
  EXPECT_NEAR(earth.normal_gravity_mps2(kPi / 2, 0.0), 9.8321849378, 1e-4);
  EXPECT_NEAR(earth.normal_gravity_mps2(kPi / 4, 0.0), 9.8061992, 5e-5);
  // A different latitude must give a different value (the test can fail).
  EXPECT_GT(earth.normal_gravity_mps2(kPi / 4, 0.0) - earth.normal_gravity_mps2(0.0, 0.0), 0.02);
  // Free-air gradient.
  EXPECT_NEAR(earth.normal_gravity_mps2(0.3, 1000.0) - earth.normal_gravity_mps2(0.3, 0.0),
              -3.086e-3, 1e-12);
}

TEST(Earth, PaperPresetGivesTable3Gravity) {
  const double lat = 40.068 * kDegToRad;
  const EarthModel earth = EarthModel::paper(lat, 50.0);
  EXPECT_DOUBLE_EQ(earth.ellipsoid.a_m, 6378245.0);
  EXPECT_DOUBLE_EQ(earth.ellipsoid.f, 1.0 / 298.3);
  EXPECT_DOUBLE_EQ(earth.omega_ie_rad_s, 7.292115147e-5);
  EXPECT_NEAR(earth.normal_gravity_mps2(lat, 50.0), 9.801, 1e-12);
  EXPECT_EQ(earth.validate(), "");
}

TEST(Earth, ValidateNamesTheBadField) {
  EarthModel earth;
  earth.omega_ie_rad_s = -1.0;
  EXPECT_NE(earth.validate().find("omega_ie_rad_s"), std::string::npos);
  earth = EarthModel();
  earth.ellipsoid.a_m = 100.0;
  EXPECT_NE(earth.validate().find("a_m"), std::string::npos);
}

TEST(Earth, TransportRateOfNorthAndEastMotion) {
  const EarthModel earth = EarthModel::wgs84();
  const double lat = 0.7, h = 100.0;
  const Eigen::Vector3d w = earth.omega_en_n(lat, h, Eigen::Vector3d(10.0, 20.0, 0.0));
  EXPECT_NEAR(w.x(), -20.0 / (earth.meridian_radius_m(lat) + h), 1e-18);
  EXPECT_NEAR(w.y(), 10.0 / (earth.prime_vertical_radius_m(lat) + h), 1e-18);
  EXPECT_NEAR(w.z(), 10.0 * std::tan(lat) / (earth.prime_vertical_radius_m(lat) + h), 1e-18);
}

}  // namespace
}  // namespace insid
