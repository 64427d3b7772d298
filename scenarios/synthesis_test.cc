#include "scenarios/synthesis.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "model/sensor_errors.h"
#include "scenarios/scenario.h"

namespace insid::scenarios {
namespace {

using json = nlohmann::json;

// A short manoeuvring flight: 60 s alignment, then take-off, acceleration, turns both ways, a
// climb; GNSS 10 Hz; no noise, no errors.
json short_flight() {
  return json::parse(R"({
    "name": "short", "imu_rate_hz": 100, "gnss_rate_hz": 10,
    "earth": {"model": "paper", "g0_mps2": 9.801},
    "initial": {"lat_deg": 40.068, "lon_deg": 116.246, "h_m": 50, "roll_deg": 0.3,
                "pitch_deg": -0.5, "yaw_deg": 20},
    "align_s": 60,
    "noise": {"grade": "none"},
    "segments": [
      {"type": "takeoff", "dh_m": 20, "vz_mps": 2},
      {"type": "speed", "speed_mps": 18, "accel_mps2": 1.5},
      {"type": "turn", "turn_deg": 120, "direction": "right", "bank_deg": 30},
      {"type": "climb", "dh_m": 20, "vz_mps": 2},
      {"type": "turn", "turn_deg": 90, "direction": "left", "rate_deg_s": 6}
    ]
  })");
}

TEST(Synthesis, StaticIncrementsAreEarthRateAndGravity) {
  const ScenarioConfig cfg = parse_scenario(short_flight(), "short");
  const Dataset ds = simulate(cfg);
  const double dt = 0.01;
  const Eigen::Matrix3d C_n_b = C_b_n_from_euler(cfg.initial.attitude).transpose();
  const Eigen::Vector3d w = C_n_b * cfg.earth.omega_ie_n(cfg.initial.lat_rad) * dt;
  const Eigen::Vector3d f = -C_n_b * cfg.earth.gravity_n(cfg.initial.lat_rad, cfg.initial.h_m) * dt;
  for (std::size_t k : {0, 100, 5999}) {
    EXPECT_NEAR((ds.imu[k].dtheta_b_rad - w).norm(), 0.0, 1e-12 * w.norm()) << k;
    // t_k - t_{k-1} in double differs from dt by up to 1e-12 relative near t = 60 s
    EXPECT_NEAR((ds.imu[k].dv_b_mps - f).norm(), 0.0, 1e-12 * f.norm()) << k;
  }
  EXPECT_NEAR(f.norm() / dt, 9.801, 1e-12);  // the paper's g at the start
}

TEST(Synthesis, RowsAreTheSameForAnyThreadCount) {
  // GIVEN the short flight (more than two blocks of 4096 IMU steps; manoeuvres cut by breakpoints)
  const ScenarioConfig cfg = parse_scenario(short_flight(), "short");
  const ScenarioPlan plan = plan_scenario(cfg);
  const auto rows = [&](int threads) {
    ImuSynthesizer synth(plan.trajectory, cfg.earth, cfg.imu_rate_hz, cfg.substeps);
    synth.run(plan.num_imu_steps, threads);
    return synth;
  };
  const ImuSynthesizer one = rows(1);
  ASSERT_GT(one.imu().size(), 2u * 4096u);
  // WHEN it is synthesized on 2 and 3 threads THEN every IMU and truth value has the same bits
  for (int threads : {2, 3}) {
    const ImuSynthesizer many = rows(threads);
    ASSERT_EQ(many.imu().size(), one.imu().size());
    for (std::size_t k = 0; k < one.imu().size(); ++k) {
      const ImuSample &a = one.imu()[k], &b = many.imu()[k];
      const TruthSample &ta = one.truth()[k], &tb = many.truth()[k];
      ASSERT_TRUE(a.t_s == b.t_s && a.dtheta_b_rad == b.dtheta_b_rad && a.dv_b_mps == b.dv_b_mps)
          << threads << " threads, row " << k;
      ASSERT_TRUE(ta.lat_rad == tb.lat_rad && ta.lon_rad == tb.lon_rad && ta.h_m == tb.h_m &&
                  ta.v_eb_n_mps == tb.v_eb_n_mps)
          << threads << " threads, row " << k;
    }
    // AND so are the states between rows (from the position grid)
    EXPECT_EQ(one.state_at(123.456).lat_rad, many.state_at(123.456).lat_rad);
  }
  EXPECT_THROW(rows(0), std::invalid_argument);
}

TEST(Synthesis, IncrementsConvergeInTheSubstepCount) {
  ScenarioConfig coarse = parse_scenario(short_flight(), "short");
  ScenarioConfig fine = coarse;
  fine.substeps = 16;
  const Dataset a = simulate(coarse), b = simulate(fine);
  double max_dtheta = 0, max_dv = 0, max_pos = 0;
  for (std::size_t k = 0; k < a.imu.size(); ++k) {
    max_dtheta = std::max(max_dtheta, (a.imu[k].dtheta_b_rad - b.imu[k].dtheta_b_rad).norm());
    max_dv = std::max(max_dv, (a.imu[k].dv_b_mps - b.imu[k].dv_b_mps).norm());
    max_pos = std::max(max_pos, std::fabs(a.truth[k].lat_rad - b.truth[k].lat_rad));
  }
  EXPECT_LT(max_dtheta, 1e-15);
  EXPECT_LT(max_dv, 1e-13);
  EXPECT_LT(max_pos * 6.4e6, 1e-8);  // metres
}

// Fine-step RK4 integration of the continuous ENU navigation equations driven by the true rates
// (attitude as a quaternion, velocity, latitude/longitude) must reproduce the analytic truth:
// checks omega_ib_b, f_ib_b and the Earth terms against each other independently of the
// increments and of the project's mechanization.
TEST(Synthesis, ContinuousNavigationEquationsReproduceTheTruth) {
  const ScenarioConfig cfg = parse_scenario(short_flight(), "short");
  const ScenarioPlan plan = plan_scenario(cfg);
  ImuSynthesizer synth(plan.trajectory, cfg.earth, cfg.imu_rate_hz, cfg.substeps);
  synth.run(plan.num_imu_steps);
  const EarthModel& E = cfg.earth;
  struct X {
    Eigen::Quaterniond q;
    Eigen::Vector3d v;
    double lat, lon;
  };
  // Derivative of the navigation state at time t (h from the truth; vertical is not the test).
  auto deriv = [&](double t, const X& x, Eigen::Vector4d& dq, Eigen::Vector3d& dv, double& dlat,
                   double& dlon) {
    const TrueState s = synth.state_at(t);
    const Eigen::Vector3d w_in = E.omega_ie_n(x.lat) + E.omega_en_n(x.lat, s.h_m, x.v);
    const Eigen::Matrix3d C = x.q.toRotationMatrix();
    dv = C * s.f_ib_b - (2 * E.omega_ie_n(x.lat) + E.omega_en_n(x.lat, s.h_m, x.v)).cross(x.v) +
         E.gravity_n(x.lat, s.h_m);
    const Eigen::Vector3d w_nb_b = s.omega_ib_b - C.transpose() * w_in;
    const Eigen::Quaterniond wq(0, w_nb_b.x(), w_nb_b.y(), w_nb_b.z());
    dq = 0.5 * (x.q * wq).coeffs();
    dlat = x.v.y() / (E.meridian_radius_m(x.lat) + s.h_m);
    dlon = x.v.x() / ((E.prime_vertical_radius_m(x.lat) + s.h_m) * std::cos(x.lat));
  };
  const double t0 = 55.0;
  const TrueState s0 = synth.state_at(t0);
  X x{Eigen::Quaterniond(s0.C_b_n), s0.v_eb_n, s0.lat_rad, s0.lon_rad};
  const double t_end = 60.0 + plan.flight_s;
  // Steps of <= 5 ms that land on every breakpoint (the angular acceleration jumps there).
  std::vector<double> knots = {t0};
  for (double b : plan.trajectory.breakpoints())
    if (b > t0 && b < t_end) knots.push_back(b);
  knots.push_back(t_end);
  auto rk4 = [&](double t, double h) {
    Eigen::Vector4d q1, q2, q3, q4;
    Eigen::Vector3d v1, v2, v3, v4;
    double a1, a2, a3, a4, o1, o2, o3, o4;
    auto shift = [&](const X& base, const Eigen::Vector4d& dq, const Eigen::Vector3d& dv,
                     double dlat, double dlon, double s) {
      X y = base;
      y.q.coeffs() += s * dq;
      y.v += s * dv;
      y.lat += s * dlat;
      y.lon += s * dlon;
      return y;
    };
    deriv(t, x, q1, v1, a1, o1);
    deriv(t + h / 2, shift(x, q1, v1, a1, o1, h / 2), q2, v2, a2, o2);
    deriv(t + h / 2, shift(x, q2, v2, a2, o2, h / 2), q3, v3, a3, o3);
    deriv(t + h, shift(x, q3, v3, a3, o3, h), q4, v4, a4, o4);
    x.q.coeffs() += h / 6 * (q1 + 2 * q2 + 2 * q3 + q4);
    x.q.normalize();
    x.v += h / 6 * (v1 + 2 * v2 + 2 * v3 + v4);
    x.lat += h / 6 * (a1 + 2 * a2 + 2 * a3 + a4);
    x.lon += h / 6 * (o1 + 2 * o2 + 2 * o3 + o4);
  };
  for (std::size_t i = 0; i + 1 < knots.size(); ++i) {
    const int n = static_cast<int>(std::ceil((knots[i + 1] - knots[i]) / 0.005));
    const double h = (knots[i + 1] - knots[i]) / n;
    for (int j = 0; j < n; ++j) rk4(knots[i] + j * h, h);
  }
  const TrueState s1 = synth.state_at(t_end);
  const Eigen::Matrix3d dC = s1.C_b_n.transpose() * x.q.toRotationMatrix();
  const Eigen::Vector3d att_err(dC(2, 1), dC(0, 2), dC(1, 0));
  EXPECT_LT(att_err.norm(), 1e-10);
  EXPECT_LT((x.v - s1.v_eb_n).norm(), 1e-8);
  EXPECT_LT(std::fabs(x.lat - s1.lat_rad) * 6.4e6, 1e-6);
  EXPECT_LT(std::fabs(x.lon - s1.lon_rad) * 6.4e6, 1e-6);
}

TEST(Geodesy, EcefRoundTrip) {
  const EarthModel E = EarthModel::paper(0.7, 50.0);
  for (double lat : {-1.2, -0.3, 0.0, 0.7, 1.4}) {
    for (double h : {-100.0, 0.0, 3000.0}) {
      double la, lo, hh;
      geodetic_from_ecef(E, ecef_from_geodetic(E, lat, 2.0, h), la, lo, hh);
      EXPECT_NEAR(la, lat, 1e-14);
      EXPECT_NEAR(lo, 2.0, 1e-14);
      EXPECT_NEAR(hh, h, 1e-7);
    }
  }
}

}  // namespace
}  // namespace insid::scenarios
