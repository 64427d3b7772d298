// Mechanization against closed-form physics.
#include "nav/mechanization.h"

#include <cmath>
#include <complex>
#include <memory>

#include <gtest/gtest.h>

#include "nav/fitness.h"
#include "test_support/test_support.h"

namespace insid {
namespace {

constexpr double kLat = 40.068 * kDegToRad;  // the paper's latitude (Table 3)
constexpr double kLon = 116.246 * kDegToRad;

// GIVEN a stationary IMU fed exact Earth-rate and gravity increments
// WHEN it navigates free-inertially in the horizontal channels for an hour
// THEN it stays put.
TEST(Mechanization, StationaryImuStaysPutForAnHour) {
  const EarthModel earth = EarthModel::paper(kLat, 50.0);
  const EulerAngles att{2 * kDegToRad, -3 * kDegToRad, 130 * kDegToRad};
  const Dataset ds = test::make_static_dataset(earth, kLat, kLon, 50.0, att, 3600.0, 0.0);
  NavState s0;
  s0.lat_rad = kLat;
  s0.lon_rad = kLon;
  s0.h_m = 50.0;
  s0.q_b_n = q_b_n_from_euler(att);
  ImuSample prev = ds.imu.front();
  prev.t_s = 0.0;
  Strapdown ins(earth, s0, prev);
  double max_dvh = 0.0;
  for (const ImuSample& inc : ds.imu) {
    ins.step_aided(inc, 50.0, 0.0);
    max_dvh = std::max(max_dvh, ins.state().v_eb_n.head<2>().norm());
  }
  EXPECT_LT(max_dvh, 1e-6);
  EXPECT_NEAR(ins.state().lat_rad, kLat, 1e-10);
  EXPECT_NEAR(ins.state().lon_rad, kLon, 1e-10);
  const EulerAngles end = euler_from_q_b_n(ins.state().q_b_n);
  EXPECT_NEAR(wrap_pi(end.yaw_rad - att.yaw_rad), 0.0, 1e-9);
}

// Horizontal velocity error of a stationary, height-aided INS started with the true attitude.
// Closed forms (Titterton & Weston, Strapdown Inertial Navigation Technology, 2nd ed., sec.
// 12.3; Britting 1971): in complex notation z = dvE + i dvN with Foucault modulation
// exp(-i W sin(lat) t) and Schuler frequency w_s = sqrt(g / R),
//   accelerometer bias B_n = B_E + i B_N:  z(t) = (B_n / w_s) sin(w_s t) exp(-i W sin(lat) t)
//   gyro bias eps_n = eps_E + i eps_N:     z(t) = R eps_n (cos(w_s t) exp(-i W sin(lat) t) - 1) * i
// (the gyro case: a constant offset R eps plus a Schuler oscillation that the Foucault term
// turns). We compare the magnitude |z(t)| every minute, within 5 % of the peak.
struct SchulerRun {
  std::vector<double> t_s;
  std::vector<std::complex<double>> z;
};

SchulerRun run_static_with_errors(const SensorErrors& errors, const EulerAngles& att) {
  const EarthModel earth = EarthModel::paper(kLat, 50.0);
  auto ds = std::make_shared<Dataset>(
      test::make_static_dataset(earth, kLat, kLon, 50.0, att, 3600.0 + 1.0, 1.0, errors));
  const NavigationProblem problem(ds);
  std::vector<double> r;
  problem.run(SensorErrors{}, C_b_n_from_euler(att), {}, r);
  SchulerRun out;
  for (std::size_t e = 0; e < problem.num_epochs(); ++e) {
    out.t_s.push_back(ds->gnss[e + 2].t_s - problem.nav_start_t_s());
    out.z.emplace_back(r[2 * e], r[2 * e + 1]);
  }
  return out;
}

TEST(Mechanization, AccelerometerBiasGivesSchulerOscillation) {
  const EarthModel earth = EarthModel::paper(kLat, 50.0);
  const double g = earth.normal_gravity_mps2(kLat, 50.0);
  const double R = std::sqrt(earth.meridian_radius_m(kLat) * earth.prime_vertical_radius_m(kLat));
  const double w_s = std::sqrt(g / R);
  const double w_f = earth.omega_ie_rad_s * std::sin(kLat);
  const EulerAngles att{0, 0, 30 * kDegToRad};
  for (int axis = 0; axis < 2; ++axis) {
    SensorErrors errors;
    errors.accel.bias[axis] = 2 * kSigmaAccelMps2;
    const SchulerRun run = run_static_with_errors(errors, att);
    const Eigen::Vector3d B_n = C_b_n_from_euler(att) * errors.accel.bias;
    const std::complex<double> B(B_n.x(), B_n.y());
    const double peak = std::abs(B) / w_s;
    for (std::size_t i = 59; i < run.t_s.size(); i += 60) {
      const double t = run.t_s[i];
      const std::complex<double> z_cf =
          B / w_s * std::sin(w_s * t) * std::exp(std::complex<double>(0, -w_f * t));
      EXPECT_NEAR(std::abs(run.z[i]), std::abs(z_cf), 0.05 * peak) << "axis " << axis << " t " << t;
    }
  }
}

TEST(Mechanization, GyroBiasGivesSchulerVelocityError) {
  const EarthModel earth = EarthModel::paper(kLat, 50.0);
  const double g = earth.normal_gravity_mps2(kLat, 50.0);
  const double R = std::sqrt(earth.meridian_radius_m(kLat) * earth.prime_vertical_radius_m(kLat));
  const double w_s = std::sqrt(g / R);
  const double w_f = earth.omega_ie_rad_s * std::sin(kLat);
  const EulerAngles att{0, 0, 30 * kDegToRad};
  for (int axis = 0; axis < 2; ++axis) {
    SensorErrors errors;
    errors.gyro.bias[axis] = 2 * kSigmaGyroRadS;
    const SchulerRun run = run_static_with_errors(errors, att);
    const Eigen::Vector3d eps_n = C_b_n_from_euler(att) * errors.gyro.bias;
    const std::complex<double> eps(eps_n.x(), eps_n.y());
    const double peak = 2 * R * std::abs(eps);
    for (std::size_t i = 59; i < run.t_s.size(); i += 60) {
      const double t = run.t_s[i];
      const std::complex<double> z_cf =
          R * eps * (std::cos(w_s * t) * std::exp(std::complex<double>(0, -w_f * t)) - 1.0);
      EXPECT_NEAR(std::abs(run.z[i]), std::abs(z_cf), 0.05 * peak) << "axis " << axis << " t " << t;
    }
  }
}

}  // namespace
}  // namespace insid
