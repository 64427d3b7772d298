#include "nav/fitness.h"

#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "data/gnss_interpolation.h"
#include "test_support/test_support.h"

namespace insid {
namespace {

constexpr double kLat = 40.068 * kDegToRad;
constexpr double kLon = 116.246 * kDegToRad;

std::shared_ptr<Dataset> static_dataset(const SensorErrors& errors, double duration_s = 1200.0) {
  const EarthModel earth = EarthModel::paper(kLat, 50.0);
  const EulerAngles att{0.5 * kDegToRad, -1.0 * kDegToRad, 75.0 * kDegToRad};
  return std::make_shared<Dataset>(
      test::make_static_dataset(earth, kLat, kLon, 50.0, att, duration_s, 600.0, errors));
}

TEST(Fitness, ZeroForAPerfectMatch) {
  for (AlignmentMode mode : {AlignmentMode::kPerCandidate, AlignmentMode::kFixed}) {
    const NavigationProblem clean(static_dataset({}), {mode});
    EXPECT_LT(clean.fitness({}), 1e-9 * static_cast<double>(clean.num_epochs()));
  }
  // Data with the paper's errors, compensated with exactly those errors.
  const NavigationProblem problem(static_dataset(test::paper_errors()));
  EXPECT_LT(problem.fitness(test::paper_errors()),
            1e-9 * static_cast<double>(problem.num_epochs()));
  EXPECT_GT(problem.fitness({}), 1e-2);
}

// IMU steps with +-30 % random jitter (insid-dataset/2: each row's own interval).
// Static data with exact increments over each jittered interval: compensated with the true
// errors the navigation is as exact as at a constant rate (the same bound as above), and
// uncompensated its fitness matches the constant-rate one (the same physics sampled otherwise).
TEST(Fitness, JitteredImuStepsNavigateLikeAConstantRate) {
  const EarthModel earth = EarthModel::paper(kLat, 50.0);
  const EulerAngles att{0.5 * kDegToRad, -1.0 * kDegToRad, 75.0 * kDegToRad};
  const SensorErrors errors = test::paper_errors();
  const auto constant = static_dataset(errors);
  auto jittered = std::make_shared<Dataset>(*constant);
  jittered->meta.format = DatasetFormat::kV2;
  const Eigen::Matrix3d C_n_b = C_b_n_from_euler(att).transpose();
  const Eigen::Vector3d omega_ib_b = C_n_b * earth.omega_ie_n(kLat);
  const Eigen::Vector3d f_ib_b = C_n_b * (-earth.gravity_n(kLat, 50.0));
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> u(-0.3, 0.3);
  jittered->imu.clear();
  double t = 0.0;
  const double dt_nominal = 0.01, t_end = constant->imu.back().t_s;
  while (t < t_end) {  // to the constant-rate data's end (the last GNSS epoch stays compared)
    const double dt = dt_nominal * (1.0 + u(rng));
    t += dt;
    ImuSample s;
    s.t_s = t;
    s.dtheta_b_rad = omega_ib_b * dt;
    s.dv_b_mps = f_ib_b * dt;
    apply_imu_errors(errors, s.t_s, dt, s.dtheta_b_rad, s.dv_b_mps);
    jittered->imu.push_back(s);
  }
  validate_dataset(*jittered);
  const NavigationProblem a(constant), b(jittered);
  EXPECT_LT(b.fitness(errors), 1e-9 * static_cast<double>(b.num_epochs()));
  EXPECT_NEAR(b.fitness({}), a.fitness({}), 1e-3 * a.fitness({}));
  // Fixed alignment (the window aligned once, without errors): the same result as well.
  const NavigationProblem a_fixed(constant, {AlignmentMode::kFixed}),
      b_fixed(jittered, {AlignmentMode::kFixed});
  EXPECT_NEAR(b_fixed.fitness(errors), a_fixed.fitness(errors), 1e-3 * a_fixed.fitness(errors));
  // The same rows declared /1 are refused (the 1 % rule), so the test is about /2.
  jittered->meta.format = DatasetFormat::kV1;
  EXPECT_THROW(validate_dataset(*jittered), DatasetError);
}

TEST(Fitness, HandComputedConstructedCase) {
  // GIVEN a perfectly static IMU but a GNSS that reports (vE, vN) = (0.3, -0.4) m/s after the
  // alignment window, THEN each epoch's horizontal error is 0.5 m/s: Eq. 15 = 0.5 * epochs,
  // the sum of squares = 0.25 * epochs, residuals (dvE, dvN) = (-0.3, 0.4).
  auto ds = static_dataset({}, 700.0);
  for (GnssSample& g : ds->gnss)
    if (g.t_s > 600.0 + 1e-9) g.v_eb_n_mps = Eigen::Vector3d(0.3, -0.4, 0.0);
  const NavigationProblem problem(ds);
  ASSERT_EQ(problem.num_epochs(), 100u);
  EXPECT_NEAR(problem.fitness({}), 50.0, 1e-6);
  EXPECT_NEAR(problem.fitness({}, FitnessKind::kSumSquares), 25.0, 1e-6);
  std::vector<double> r;
  problem.residuals({}, r);
  ASSERT_EQ(r.size(), 200u);
  EXPECT_NEAR(r[0], -0.3, 1e-8);
  EXPECT_NEAR(r[1], 0.4, 1e-8);
  EXPECT_NEAR(r[199], 0.4, 1e-8);
}

TEST(Fitness, OneSumOfResidualsForEq15AndSumOfSquares) {
  // Hand-computed: epochs (3, 4) and (0, -1) m/s: Eq. 15 = 5 + 1, sum of squares = 25 + 1.
  const std::vector<double> r = {3.0, 4.0, 0.0, -1.0};
  EXPECT_EQ(fitness_from_residuals(r), 6.0);
  EXPECT_EQ(fitness_from_residuals(r, FitnessKind::kSumSquares), 26.0);
  EXPECT_EQ(fitness_from_residuals(std::vector<double>{}), 0.0);
  // NavigationProblem::fitness is this sum of its residuals, bit for bit.
  const NavigationProblem problem(static_dataset(test::paper_errors(), 700.0));
  std::vector<double> residuals;
  problem.residuals({}, residuals);
  for (FitnessKind kind : {FitnessKind::kEq15, FitnessKind::kSumSquares})
    EXPECT_EQ(problem.fitness({}, kind), fitness_from_residuals(residuals, kind));
}

TEST(Fitness, PerCandidateAlignmentDiffersFromFixed) {
  const auto ds = static_dataset(test::paper_errors());
  const NavigationProblem per(ds, {AlignmentMode::kPerCandidate});
  const NavigationProblem fixed(ds, {AlignmentMode::kFixed});
  // Fixed: the attitude does not depend on the candidate.
  EXPECT_LT((fixed.initial_attitude({}) - fixed.initial_attitude(test::paper_errors())).norm(),
            1e-15);
  EXPECT_GT((per.initial_attitude({}) - per.initial_attitude(test::paper_errors())).norm(), 1e-6);
  // Compensating the true errors: per-candidate re-aligns with the compensated data and
  // matches; fixed keeps the attitude levelled on the biased data, which then mismatches.
  EXPECT_LT(per.fitness(test::paper_errors()), 1e-9 * static_cast<double>(per.num_epochs()));
  EXPECT_GT(fixed.fitness(test::paper_errors()), 1e-2);
}

TEST(Fitness, InterpolatedGnssEpochsAndModes) {
  EXPECT_EQ(alignment_mode_from_string("fixed"), AlignmentMode::kFixed);
  EXPECT_THROW(alignment_mode_from_string("sometimes"), std::invalid_argument);
  std::vector<GnssSample> g(2);
  g[0].t_s = 1.0;
  g[1].t_s = 3.0;
  g[1].v_eb_n_mps = Eigen::Vector3d(2.0, -4.0, 6.0);
  g[1].h_m = 10.0;
  const GnssSample mid = interpolate_gnss(g, 1.5);
  EXPECT_DOUBLE_EQ(mid.v_eb_n_mps.x(), 0.5);
  EXPECT_DOUBLE_EQ(mid.v_eb_n_mps.y(), -1.0);
  EXPECT_DOUBLE_EQ(mid.h_m, 2.5);
  EXPECT_DOUBLE_EQ(interpolate_gnss(g, 10.0).h_m, 10.0);
}

TEST(Fitness, RejectsDataWithoutNavigationPart) {
  auto ds = static_dataset({}, 700.0);
  ds->meta.align_s = 700.0;
  EXPECT_THROW(NavigationProblem{ds}, std::invalid_argument);
}

// ----- windowed fitness (nav/fitness.h "Windowed fitness") ---------------------------------------

NavigationOptions windowed(double window_s, AlignmentMode mode = AlignmentMode::kPerCandidate) {
  NavigationOptions options;
  options.alignment = mode;
  options.window_s = window_s;
  return options;
}

TEST(WindowedFitness, BadWindowsAreRefusedNamingTheValue) {
  const auto ds = static_dataset({}, 700.0);  // GNSS at 1 Hz
  for (double bad : {-1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    try {
      NavigationProblem problem(ds, windowed(bad));
      ADD_FAILURE() << "window_s = " << bad << " accepted";
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find("window_s = "), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(">= 0"), std::string::npos) << e.what();
    }
  }
  // Shorter than one GNSS period (1 s here): windows without an epoch.
  try {
    NavigationProblem problem(ds, windowed(0.5));
    ADD_FAILURE() << "window_s = 0.5 accepted at 1 Hz GNSS";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("window_s = 0.5 s is shorter than one GNSS period (1 s"),
              std::string::npos)
        << e.what();
  }
  EXPECT_NO_THROW(NavigationProblem(ds, windowed(1.0)));  // one period is enough
}

TEST(WindowedFitness, RestartEpochsFollowTheDocumentedRule) {
  // 600 s alignment, navigation from t0 = 600 s to the last IMU epoch at 700 s, IMU at 100 Hz.
  const auto ds = static_dataset({}, 700.0);
  const NavigationProblem ten(ds, windowed(10.0));
  // t0 + 10 j for j = 1..9 (t = 700 is the last epoch: no restart after the last step).
  ASSERT_EQ(ten.window_restarts().size(), 9u);
  EXPECT_EQ(ten.num_windows(), 10u);
  for (std::size_t j = 0; j < 9; ++j) {
    const WindowRestart& r = ten.window_restarts()[j];
    EXPECT_NEAR(r.t_s, 610.0 + 10.0 * static_cast<double>(j), 1e-9) << j;
    EXPECT_EQ(ds->imu[r.imu_index].t_s, r.t_s);
  }
  // 7.3 s: the first IMU epoch at or after 600 + 7.3 j (epochs every 10 ms fall on it).
  const NavigationProblem odd(ds, windowed(7.3));
  ASSERT_EQ(odd.window_restarts().size(), 13u);  // 607.3 ... 694.9
  EXPECT_NEAR(odd.window_restarts().back().t_s, 694.9, 1e-9);
  // Nothing to restart: W = 0, or W reaching the last epoch.
  EXPECT_TRUE(NavigationProblem(ds, windowed(0.0)).window_restarts().empty());
  EXPECT_TRUE(NavigationProblem(ds, windowed(100.0)).window_restarts().empty());
  EXPECT_EQ(NavigationProblem(ds, windowed(99.0)).window_restarts().size(), 1u);
}

TEST(WindowedFitness, AWindowLongerThanTheFlightIsOneRunBitForBit) {
  const auto ds = static_dataset(test::paper_errors(), 900.0);
  for (AlignmentMode mode : {AlignmentMode::kPerCandidate, AlignmentMode::kFixed}) {
    const NavigationProblem one(ds, windowed(0.0, mode)), longer(ds, windowed(1e6, mode));
    std::vector<double> r_one, r_longer;
    one.residuals({}, r_one);
    longer.residuals({}, r_longer);
    EXPECT_EQ(r_one, r_longer);
    EXPECT_EQ(one.fitness({}), longer.fitness({}));
    EXPECT_EQ(one.fitness({}, FitnessKind::kSumSquares),
              longer.fitness({}, FitnessKind::kSumSquares));
  }
}

TEST(WindowedFitness, ARestartResetsPositionAndVelocity) {
  // GIVEN clean static data aligned once as recorded (the attitude is the true one) and a
  // candidate that compensates an accelerometer bias the IMU does not have (5 mg on x, -3 mg on
  // y): its horizontal velocity error grows as b t (Schuler: 84 min period, far longer).
  const auto ds = static_dataset({}, 1200.0);  // 600 s navigated, GNSS at 1 Hz
  SensorErrors candidate;
  candidate.accel.bias.x() = 0.05;
  candidate.accel.bias.y() = -0.03;
  const double b = std::hypot(0.05, -0.03);
  const double window_s = 10.0;
  const NavigationProblem one(ds, windowed(0.0, AlignmentMode::kFixed));
  const NavigationProblem win(ds, windowed(window_s, AlignmentMode::kFixed));
  std::vector<double> r_one, r_win;
  one.residuals(candidate, r_one);
  win.residuals(candidate, r_win);
  ASSERT_EQ(r_one.size(), r_win.size());
  double max_one = 0.0, max_win = 0.0, last_win = 0.0;
  for (std::size_t e = 0; e < one.num_epochs(); ++e) {
    max_one = std::max(max_one, std::hypot(r_one[2 * e], r_one[2 * e + 1]));
    max_win = std::max(max_win, std::hypot(r_win[2 * e], r_win[2 * e + 1]));
  }
  last_win = std::hypot(r_win[r_win.size() - 2], r_win.back());
  // THEN windowed, every residual stays within what the bias builds in one window (b W, within
  // 2 %: the tilt the velocity error makes through the transport rate is tiny over 10 s), and
  // a window's last epoch shows it in full; in one run the error keeps growing (b * 600 s).
  EXPECT_LE(max_win, 1.02 * b * window_s);
  EXPECT_GE(last_win, 0.98 * b * window_s);
  EXPECT_GE(max_one, 30.0 * b * window_s);
  // The epoch right after a restart (1 s into its window) holds only that second's error.
  const std::size_t after = 10;  // epoch at t = 611 s, window from 610 s
  EXPECT_NEAR(std::hypot(r_win[2 * after], r_win[2 * after + 1]), b * 1.0, 0.02 * b);
  // The windowed fitness is far smaller than the one-run fitness.
  EXPECT_LT(win.fitness(candidate), 0.1 * one.fitness(candidate));
}

}  // namespace
}  // namespace insid
