// Honest sd from every estimator (identification/README.md, "How sure an estimate
// is"), on the drone flight of identification/mems_study.h (50 Hz IMU, 5 Hz GNSS, 8 s on the
// ground, MEMS biases drawn per seed, the IMU noise of the shared quadcopter log's flight):
//   - the IMU noise the EKF-RTS measures in the flight (no noise block) is the simulated one;
//   - the EKF-RTS's sd rule: a filter told noise levels k = 4 times too small (every one of its
//     four) has smoothed sd about k times too small and innovations k^2 too large per degree of
//     freedom; the reported sd (use_filter_sd) comes out within 25 % of the one the filter
//     reports with the true levels;
//   - a not_converged estimate (an estimate far from the optimum: the box centre) carries
//     sd = sqrt(sd^2 + step^2), which covers its distance to the least-squares optimum;
//   - coverage: over a few seeds of a short drone flight without a noise block (as an imported
//     log: the filter takes the grade's noise, 40x below the flight's gyro noise), the EKF-RTS's
//     reported 95 % intervals cover most truths (they covered few before the rule).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "data/noise_model.h"
#include "identification/ekf_rts.h"
#include "identification/grade.h"
#include "identification/mems_study.h"
#include "identification/uncertainty.h"
#include "optimizers/registry.h"

namespace insid {
namespace {

constexpr double kZ95 = 1.959963984540054;

mems_study::Spec drone(double flight_s, bool noise_in_meta) {
  mems_study::Spec spec;
  spec.kind = "drone";
  spec.flight_s = flight_s;
  spec.noise_in_meta = noise_in_meta;
  return spec;
}

// A report with only what use_filter_sd reads: the parameters' names, units and boxes.
UncertaintyReport bare_report(const std::vector<std::string>& names, double box_sigma,
                              double gauss_newton_sd_sigma) {
  UncertaintyReport report;
  const SensorGrade& mems = sensor_grade("mems");
  for (const std::string& name : names) {
    ParameterUncertainty p;
    p.name = name;
    p.sigma_si = mems.parameter(name).sigma;
    p.box_width_sigma = 2.0 * box_sigma;
    p.share_not_absorbed = 1.0;
    p.sd_si = gauss_newton_sd_sigma * p.sigma_si;  // the Gauss-Newton sd
    report.parameters.push_back(p);
  }
  return report;
}

// GIVEN a drone flight with the shared log's in-flight IMU noise WHEN its IMU noise is measured
// after the static window (what the EKF-RTS uses without a noise block) THEN it comes out within
// 10 % of the simulated random walks, though the flight turns, climbs and speeds up.
TEST(HonestSd, FlightImuNoiseIsMeasuredFromTheData) {
  const mems_study::Spec spec = drone(60.0, true);
  const auto data = mems_study::flight(spec, 5);
  const NoiseLevels measured = estimate_flight_imu_noise(*data);
  std::cout << "[ honest sd ] measured ARW " << measured.arw_deg_rth << " deg/sqrt(h) (simulated "
            << spec.drone_arw_deg_rth << "), VRW " << measured.vrw_mps_rth << " m/s/sqrt(h) ("
            << spec.drone_vrw_mps_rth << ")\n";
  EXPECT_NEAR(measured.arw_deg_rth, spec.drone_arw_deg_rth, 0.1 * spec.drone_arw_deg_rth);
  EXPECT_NEAR(measured.vrw_mps_rth, spec.drone_vrw_mps_rth, 0.1 * spec.drone_vrw_mps_rth);
}

// GIVEN a drone flight whose noise levels are known (meta.json) WHEN the EKF-RTS runs once with
// the true levels and once told all four levels k = 4 times too small THEN the understated
// filter's smoothed sd are ~k times smaller, its innovations' chi-square per dof ~k^2 larger, and
// use_filter_sd scales its sd back to within 25 % of the right filter's.
TEST(HonestSd, FilterWithUnderstatedNoiseGetsItsSdScaledUpByThatFactor) {
  const mems_study::Spec spec = drone(60.0, true);
  const auto data = mems_study::flight(spec, 3);
  NavigationOptions options;
  options.initial_attitude.mode = InitialAttitudeMode::kLevelHeading;
  const NavigationProblem navigation(data, options);
  const SensorGrade& mems = sensor_grade("mems");
  const NoiseLevels truth = *data->meta.noise;
  constexpr double k = 4.0;
  EkfRtsParams right, under;
  right.arw_deg_rth = truth.arw_deg_rth;
  right.vrw_mps_rth = truth.vrw_mps_rth;
  right.gnss_vel_sigma_mps = truth.gnss_vel_sigma_mps;
  right.gnss_pos_sigma_m = truth.gnss_pos_sigma_m;
  under.arw_deg_rth = truth.arw_deg_rth / k;
  under.vrw_mps_rth = truth.vrw_mps_rth / k;
  under.gnss_vel_sigma_mps = truth.gnss_vel_sigma_mps / k;
  under.gnss_pos_sigma_m = truth.gnss_pos_sigma_m / k;
  const auto setup = ekf_grade_setup(navigation, mems);
  const EkfRtsResult r = run_ekf_rts(navigation, right, SensorErrors{}, setup);
  const EkfRtsResult u = run_ekf_rts(navigation, under, SensorErrors{}, setup);
  std::cout << "[ honest sd ] NIS per dof: right levels " << r.nis_per_dof << ", levels / " << k
            << " " << u.nis_per_dof << " (" << u.nis_dof << " dof)\n";
  EXPECT_GT(u.nis_per_dof / r.nis_per_dof, 0.6 * k * k);
  EXPECT_LT(u.nis_per_dof / r.nis_per_dof, 1.4 * k * k);
  const std::vector<std::string>& names = mems_study::parameter_names(spec);
  // A Gauss-Newton sd far below the filters' (1e-4 sigma): the floor of a rejected filter model
  // does not bind, the scale alone is measured.
  UncertaintyReport right_report = bare_report(names, spec.box_sigma, 1e-4);
  UncertaintyReport under_report = right_report;
  FilterSd right_sd{{}, r.nis_per_dof, r.nis_dof}, under_sd{{}, u.nis_per_dof, u.nis_dof};
  for (const std::string& name : names) {
    right_sd.sd_si.push_back(r.std.at(name));
    under_sd.sd_si.push_back(u.std.at(name));
  }
  use_filter_sd(right_report, right_sd);
  use_filter_sd(under_report, under_sd);
  for (std::size_t j = 0; j < names.size(); ++j) {
    const double raw_ratio = under_sd.sd_si[j] / right_sd.sd_si[j];
    const double reported_ratio =
        *under_report.parameters[j].sd_si / *right_report.parameters[j].sd_si;
    std::cout << "[ honest sd ] " << names[j] << ": smoothed sd ratio " << raw_ratio
              << ", reported sd ratio " << reported_ratio << "\n";
    EXPECT_LT(raw_ratio, 0.5) << names[j] << ": the understated filter should be overconfident";
    EXPECT_GT(reported_ratio, 0.8) << names[j];
    EXPECT_LT(reported_ratio, 1.25) << names[j];
  }
  // Its innovations at 16x their expected chi-square reject its model (> misfit_min_ratio 4):
  // its sd is then never below the Gauss-Newton sd at its point (here 1 sigma, wider than its
  // own); the right filter's model stands and keeps its own sd.
  EXPECT_FALSE(right_report.filter_model_rejected);
  EXPECT_TRUE(under_report.filter_model_rejected);
  UncertaintyReport under_wide = bare_report(names, spec.box_sigma, 1.0);
  UncertaintyReport right_wide = under_wide;
  use_filter_sd(under_wide, under_sd);
  use_filter_sd(right_wide, right_sd);
  for (std::size_t j = 0; j < names.size(); ++j) {
    const double sigma = under_wide.parameters[j].sigma_si;
    EXPECT_NEAR(*under_wide.parameters[j].sd_si, sigma, 1e-12 * sigma) << names[j];
    EXPECT_NEAR(*right_wide.parameters[j].sd_si, *right_report.parameters[j].sd_si, 1e-12 * sigma)
        << names[j];
  }
}

// GIVEN the least-squares problem of a drone flight and an estimate far from its optimum (the
// box centre, the truths lying several sigma away) WHEN its uncertainty is estimated THEN every
// parameter flagged not_converged carries sd = sqrt(sd_without_step^2 + step^2), and its 95 %
// interval covers the least-squares optimum that LM finds.
TEST(HonestSd, NotConvergedSdCoversItsStepToTheOptimum) {
  const mems_study::Spec spec = drone(60.0, false);
  const auto data = mems_study::flight(spec, 2);
  NavigationOptions options;
  options.window_s = spec.window_s;
  options.initial_attitude.mode = InitialAttitudeMode::kLevelHeading;
  const auto navigation = std::make_shared<const NavigationProblem>(data, options);
  const SensorGrade& mems = sensor_grade("mems");
  std::vector<EstimatedParameter> estimated;
  for (const std::string& name : mems_study::parameter_names(spec)) {
    char item[160];
    std::snprintf(item, sizeof(item), "%s:%.17g:-8:8", name.c_str(), mems.sigma(name));
    estimated.push_back(mems.parameter(item));
  }
  opt::EvaluatorOptions evaluator;
  evaluator.parallelism = opt::Parallelism::kSerial;
  const InsIdentificationProblem problem(navigation, ParameterMapping(estimated),
                                         FitnessKind::kEq15, evaluator);
  const int n = problem.mapping().dimension();
  UncertaintyOptions uo;
  uo.replicas = 20;
  uo.threads = 1;
  uo.criterion = UncertaintyCriterion::kLeastSquares;
  const UncertaintyReport far = estimate_uncertainty(problem, Eigen::VectorXd::Zero(n), uo);
  opt::RunConfig config;
  config.max_iterations = 0;
  config.max_evaluations = 300;
  auto lm = opt::make_optimizer("lm", problem.bounds(), config, {});
  const Eigen::VectorXd optimum = problem.mapping().to_sigma(opt::run(*lm, problem).best_x);
  int flagged = 0, missed_without_step = 0;
  for (int j = 0; j < n; ++j) {
    const ParameterUncertainty& p = far.parameters[static_cast<std::size_t>(j)];
    if (std::find(p.flags.begin(), p.flags.end(), "not_converged") == p.flags.end()) continue;
    ++flagged;
    ASSERT_TRUE(p.sd_without_step_si.has_value()) << p.name;
    EXPECT_NEAR(*p.sd_si, std::hypot(*p.sd_without_step_si, p.step_to_optimum_sigma * p.sigma_si),
                1e-12 * *p.sd_si)
        << p.name;
    const double distance_sigma = std::abs(optimum[j]);  // from the box centre
    std::cout << "[ honest sd ] " << p.name << ": distance to the LM optimum " << distance_sigma
              << " sigma, one step " << p.step_to_optimum_sigma << ", sd without / with it "
              << *p.sd_without_step_si / p.sigma_si << " / " << *p.sd_si / p.sigma_si << " sigma\n";
    EXPECT_LE(distance_sigma, kZ95 * *p.sd_si / p.sigma_si) << p.name;
    missed_without_step += distance_sigma > kZ95 * *p.sd_without_step_si / p.sigma_si;
  }
  EXPECT_GE(flagged, 3) << "the box centre lies far from this flight's optimum";
  EXPECT_GE(missed_without_step, 2) << "without the step the intervals should miss the optimum";
}

// GIVEN short drone flights without a noise block (as an imported log) WHEN EKF-RTS runs as
// `insid identify --algo ekf-rts` reports it THEN its 95 % intervals cover at least 90 % of the
// truths over 4 seeds x 6 biases (before the rule: the filter's sd times the fitness's misfit
// covered about a third of them).
TEST(HonestSd, EkfRtsIntervalsCoverTheTruthsOfDroneFlights) {
  mems_study::Spec spec = drone(60.0, false);
  spec.replicas = 30;
  spec.threads = 2;
  int covered = 0, total = 0;
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const auto data = mems_study::flight(spec, seed);
    const Eigen::VectorXd truth = mems_study::truth_si(spec, seed);
    const mems_study::Answer a = mems_study::ekf_rts_reported(data, spec);
    // The filter measured the flight's noise itself: its innovations should not reject it.
    ASSERT_TRUE(a.uncertainty.has_value());
    EXPECT_FALSE(a.uncertainty->filter_model_rejected)
        << "seed " << seed << ": NIS per dof " << a.uncertainty->filter_nis_per_dof.value_or(0.0);
    for (Eigen::Index k = 0; k < truth.size(); ++k) {
      const double z = (a.estimate_si[k] - truth[k]) / a.sd_si[k];
      covered += std::abs(z) <= kZ95;
      ++total;
      std::cout << "[ honest sd ] seed " << seed << " "
                << mems_study::parameter_names(spec)[static_cast<std::size_t>(k)] << " error/sd "
                << z << "\n";
    }
  }
  std::cout << "[ honest sd ] EKF-RTS covered " << covered << "/" << total << "\n";
  EXPECT_GE(covered, static_cast<int>(std::ceil(0.9 * total)));
}

}  // namespace
}  // namespace insid
