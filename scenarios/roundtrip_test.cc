// Round trip through the project's own navigation: a noise-free, error-free `rich` flight
// (45 min after a 10 min alignment) navigated by NavigationProblem::run must stay within
// 1e-4 m/s horizontal velocity and 0.5 m horizontal position of the truth, with the true
// initial attitude and with the attitude aligned from the data.
#include <cmath>
#include <memory>
#include <optional>

#include <gtest/gtest.h>

#include "core/fitness.h"
#include "scenarios/scenario.h"

namespace insid::scenarios {
namespace {

struct RoundTrip {
  double max_dv_h = 0;     // m/s
  double max_dpos_h = 0;   // m
  double max_att = 0;      // rad
  double max_resid = 0;    // m/s, INS minus GNSS at GNSS epochs
  std::size_t steps = 0;
};

const Dataset& rich_clean() {
  static const Dataset ds = [] {
    ScenarioConfig c = preset_scenario("rich");
    c.noise = noise_grade("none");
    c.injected = SensorErrors{};
    return simulate(c);
  }();
  return ds;
}

RoundTrip navigate(const Dataset& ds, const SensorErrors& candidate, bool true_attitude) {
  auto shared = std::make_shared<const Dataset>(ds);
  NavigationProblem problem(shared);
  const std::size_t k0 = problem.nav_begin();
  std::optional<Eigen::Matrix3d> C0;
  // truth[k] is the state at imu[k].t_s; navigation starts at imu[k0 - 1].t_s.
  if (true_attitude) C0 = C_b_n_from_euler(ds.truth[k0 - 1].attitude);
  RoundTrip r;
  const EarthModel& E = ds.meta.earth;
  std::size_t k = k0;
  std::vector<double> resid;
  problem.run(candidate, C0, [&](const NavState& s) {
    const TruthSample& t = ds.truth[k++];
    EXPECT_NEAR(s.t_s, t.t_s, 1e-9);
    r.max_dv_h = std::max(r.max_dv_h, (s.v_eb_n - t.v_eb_n_mps).head<2>().norm());
    const double dn = (s.lat_rad - t.lat_rad) * (E.meridian_radius_m(t.lat_rad) + t.h_m);
    const double de = (s.lon_rad - t.lon_rad) * (E.prime_vertical_radius_m(t.lat_rad) + t.h_m) *
                      std::cos(t.lat_rad);
    r.max_dpos_h = std::max(r.max_dpos_h, std::hypot(dn, de));
    const Eigen::Matrix3d dC =
        C_b_n_from_euler(t.attitude).transpose() * s.q_b_n.toRotationMatrix();
    r.max_att = std::max(r.max_att, Eigen::Vector3d(dC(2, 1), dC(0, 2), dC(1, 0)).norm());
    ++r.steps;
  }, resid);
  for (double v : resid) r.max_resid = std::max(r.max_resid, std::fabs(v));
  return r;
}

TEST(RoundTrip, RichFlightWithTrueInitialAttitude) {
  const Dataset& ds = rich_clean();
  const RoundTrip r = navigate(ds, SensorErrors{}, true);
  EXPECT_GE(r.steps, 240000u);  // >= 40 min after the alignment
  EXPECT_LT(r.max_dv_h, 1e-4);
  EXPECT_LT(r.max_dpos_h, 0.5);
  EXPECT_LT(r.max_resid, 1e-4);
  std::printf("round trip (true attitude): max |dv_h| = %.3g m/s, max |dpos_h| = %.3g m, "
              "max attitude error = %.3g rad\n", r.max_dv_h, r.max_dpos_h, r.max_att);
}

TEST(RoundTrip, RichFlightWithAlignmentFromTheData) {
  const Dataset& ds = rich_clean();
  const RoundTrip r = navigate(ds, SensorErrors{}, false);
  EXPECT_LT(r.max_dv_h, 1e-4);
  EXPECT_LT(r.max_dpos_h, 0.5);
  std::printf("round trip (aligned): max |dv_h| = %.3g m/s, max |dpos_h| = %.3g m, "
              "max attitude error = %.3g rad\n", r.max_dv_h, r.max_dpos_h, r.max_att);
}

// Injected IMU errors compensated with the exact candidate navigate like clean data; GNSS-side
// effects (lever arm, latency) given to the candidate leave residuals at the same level.
TEST(RoundTrip, ExactCandidateCompensatesInjectedErrors) {
  ScenarioConfig c = preset_scenario("rich");
  c.noise = noise_grade("none");
  c.flight_s = 1200.0;
  set_effect(c.injected, "accel_scale_x", 2e-4);
  set_effect(c.injected, "gyro_misalign_xy", 1e-4);
  set_effect(c.injected, "gyro_bias_drift_x", 1e-11);
  set_effect(c.injected, "lever_arm_x", 0.8);
  set_effect(c.injected, "lever_arm_z", -0.3);
  set_effect(c.injected, "gnss_latency", 0.02);
  const Dataset ds = simulate(c);
  const RoundTrip exact = navigate(ds, c.injected, false);
  EXPECT_LT(exact.max_dv_h, 1e-4);
  // The residual limit is looser than the navigation error: measured 6.2e-4 m/s, almost all of
  // it from lever_arm_z (2.8e-4 m/s alone) during the roll-in/roll-out of the bank turns, where
  // the antenna velocity uses omega_ib_b extrapolated from the last two IMU increments. Not yet
  // explained further; the bound keeps a 3x margin over the measured value.
  EXPECT_LT(exact.max_resid, 2e-3);
  // ... and without the GNSS-side effects / uncompensated the data are far off.
  SensorErrors imu_only = c.injected;
  imu_only.lever_arm_b_m.setZero();
  imu_only.gnss_latency_s = 0.0;
  const RoundTrip no_gnss_effects = navigate(ds, imu_only, false);
  EXPECT_GT(no_gnss_effects.max_resid, 50 * 2e-3);
  const RoundTrip raw = navigate(ds, SensorErrors{}, false);
  EXPECT_GT(raw.max_dv_h, 1000 * exact.max_dv_h);
  std::printf("exact candidate: max |dv_h| = %.3g m/s, max residual = %.3g m/s; without lever "
              "arm/latency: max residual %.3g m/s; raw: max |dv_h| %.3g m/s\n",
              exact.max_dv_h, exact.max_resid, no_gnss_effects.max_resid, raw.max_dv_h);
}

}  // namespace
}  // namespace insid::scenarios
