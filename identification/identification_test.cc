
#include <cmath>
#include <filesystem>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "identification/ekf_rts.h"
#include "identification/identify.h"
#include "identification/ins_problem.h"
#include "identification/local_fit.h"
#include "optimizers/registry.h"
#include "test_support/files.h"
#include "test_support/test_support.h"

namespace insid {
namespace {

constexpr double kLat = 40.068 * kDegToRad;

// Static data whose biases switch on after the alignment window, navigated with a fixed
// (recorded-data) alignment: the attitude is then the true one and all four biases show in the
// Schuler-type velocity error. (With biases present during alignment, levelling and
// gyrocompassing would absorb accel_bias_x/y and the east gyro bias on static data.)
std::shared_ptr<const NavigationProblem> static_problem() {
  static const auto nav = [] {
    Dataset ds = test::make_static_dataset(EarthModel::paper(kLat, 50.0), kLat, 2.0, 50.0,
                                           {0.0, 0.0, 0.7}, 1800.0, 600.0);
    const SensorErrors errors = test::paper_errors();
    for (ImuSample& s : ds.imu)
      if (s.t_s > 600.0 + 1e-9) apply_imu_errors(errors, 0.0, 0.01, s.dtheta_b_rad, s.dv_b_mps);
    return std::make_shared<const NavigationProblem>(std::make_shared<const Dataset>(ds),
                                                     NavigationOptions{AlignmentMode::kFixed});
  }();
  return nav;
}

TEST(Identification, MappingRoundTripsAndUsesThePaperBox) {
  const ParameterMapping m(EstimatedParameter::paper_four());
  const Eigen::Vector4d x(-1.0, 0.0, 0.5, 1.0);
  const Eigen::VectorXd s = m.to_sigma(x);
  EXPECT_DOUBLE_EQ(s[0], -4.0);
  EXPECT_DOUBLE_EQ(s[1], 0.0);
  EXPECT_DOUBLE_EQ(s[2], 2.0);
  EXPECT_DOUBLE_EQ(s[3], 4.0);
  EXPECT_LT((m.from_sigma(s) - x).norm(), 1e-15);
  const SensorErrors e = m.to_errors(x);
  EXPECT_DOUBLE_EQ(e.gyro.bias.x(), 2.0 * kSigmaGyroRadS);
  EXPECT_DOUBLE_EQ(e.accel.bias.x(), -4.0 * kSigmaAccelMps2);
  EXPECT_DOUBLE_EQ(m.sigma_per_unit(0), 4.0);
}

// `--param NAME_sigma=V` for a distance parameter NAME (its unit kBoxDistance: DVPIO's d_initial)
// is that distance in sigma units, converted to the normalised box; an algorithm's own parameter
// whose name ends in _sigma (ekf-rts's initial_bias_sigma, a prior in catalogue sigma units) and
// NAME_sigma for a parameter that is no distance pass unchanged.
TEST(Identification, AlgorithmParameterInBoxConvertsOnlyDistances) {
  const ParameterMapping m(EstimatedParameter::paper_four());  // [-4, 4] sigma -> [-1, 1]
  const opt::ParameterInfoList dvpio = opt::parameter_info("dvpio");
  const auto [d_key, d_value] = m.algorithm_parameter_in_box("d_initial_sigma", 0.4, dvpio);
  EXPECT_EQ(d_key, "d_initial");
  EXPECT_DOUBLE_EQ(d_value, 0.1);
  const auto [t_key, t_value] = m.algorithm_parameter_in_box("dist_threshold_sigma", 0.2, dvpio);
  EXPECT_EQ(t_key, "dist_threshold");
  EXPECT_DOUBLE_EQ(t_value, 0.05);
  // R is a factor, not a distance: R_sigma is no spelling of it (the optimizer refuses the key).
  const auto [r_key, r_value] = m.algorithm_parameter_in_box("R_sigma", 0.2, dvpio);
  EXPECT_EQ(r_key, "R_sigma");
  EXPECT_DOUBLE_EQ(r_value, 0.2);
  EXPECT_THROW(opt::make_optimizer("dvpio", opt::Bounds::unit_box(4), {}, {{r_key, r_value}}),
               std::invalid_argument);
  const auto [s_key, s_value] =
      m.algorithm_parameter_in_box("initial_step_sigma", 0.8, opt::parameter_info("bobyqa"));
  EXPECT_EQ(s_key, "initial_step");
  EXPECT_DOUBLE_EQ(s_value, 0.2);
  const opt::ParameterInfoList ekf = EkfRtsParams{}.info();
  const auto [e_key, e_value] = m.algorithm_parameter_in_box("initial_bias_sigma", 36000.0, ekf);
  EXPECT_EQ(e_key, "initial_bias_sigma");
  EXPECT_DOUBLE_EQ(e_value, 36000.0);
  // The setting reaches the filter: no "unknown parameter" from the registry's factory.
  EXPECT_NO_THROW(EkfRtsParams::from_map({{e_key, e_value}}));
  const auto [plain_key, plain_value] = m.algorithm_parameter_in_box("w", 0.7, dvpio);
  EXPECT_EQ(plain_key, "w");
  EXPECT_DOUBLE_EQ(plain_value, 0.7);
}

TEST(Identification, EstimateSpecParsingRejectsBadInput) {
  const EstimatedParameter p = EstimatedParameter::parse("gyro_scale_z:2e-4:-3:5");
  EXPECT_EQ(p.name, "gyro_scale_z");
  EXPECT_DOUBLE_EQ(p.sigma, 2e-4);
  EXPECT_DOUBLE_EQ(p.upper_sigma, 5.0);
  EXPECT_THROW(EstimatedParameter::parse("gyro_bias_q"), std::invalid_argument);
  EXPECT_THROW(EstimatedParameter::parse("gyro_bias_x:abc"), std::invalid_argument);
  EXPECT_THROW(EstimatedParameter::parse("gyro_bias_x:1:3:2"), std::invalid_argument);
  EXPECT_THROW(EstimatedParameter::parse("gyro_bias_x:-1"), std::invalid_argument);
  EXPECT_THROW(ParameterMapping({EstimatedParameter::parse("gyro_bias_x"),
                                 EstimatedParameter::parse("gyro_bias_x")}),
               std::invalid_argument);
}

// A search box beyond what is physical is refused by name up front (a
// 1e300-sigma accelerometer box ran into "coarse alignment ... (at a pole?)"); boxes users do
// give (a MEMS gyro z at 8 sigma, a 4 s latency box) pass.
TEST(Identification, EstimateSpecBeyondPhysicalLimitsIsRefusedNamingTheLimit) {
  const auto error_of = [](const std::string& text) -> std::string {
    try {
      EstimatedParameter::parse(text);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "(accepted)";
  };
  const std::string accel = error_of("accel_bias_x:1e300");
  EXPECT_NE(accel.find("--estimate 'accel_bias_x:1e300': the search box reaches 4e+300 m/s^2"),
            std::string::npos)
      << accel;
  EXPECT_NE(accel.find("50 g"), std::string::npos) << accel;
  EXPECT_NE(error_of("gyro_bias_z:40"), "(accepted)");         // 160 rad/s > 2000 deg/s
  EXPECT_NE(error_of("gyro_scale_x:0.5:-4:4"), "(accepted)");  // 200 %
  EXPECT_NE(error_of("lever_arm_x:1e6"), "(accepted)");
  EXPECT_NE(error_of("gnss_latency:inf"), "(accepted)");
  EXPECT_EQ(error_of("gyro_bias_z:0.0017453292519943296:-8:8"), "(accepted)");
  EXPECT_EQ(error_of("gnss_latency:0.1:-4:4"), "(accepted)");
  EXPECT_EQ(error_of("lever_arm_z:0.5:-4:4"), "(accepted)");
  EXPECT_EQ(error_of("accel_bias_drift_x"), "(accepted)");
}

TEST(Identification, LocalFitFindsTheInjectedBiasesOnNoiseFreeData) {
  const InsIdentificationProblem problem(static_problem(),
                                         ParameterMapping(EstimatedParameter::paper_four()));
  const LocalFitResult fit = local_fit(problem, Eigen::VectorXd::Zero(4));
  const Eigen::Vector4d truth(-2.0, 1.5, 2.0, -1.5);
  EXPECT_LT((fit.value_sigma - truth).cwiseAbs().maxCoeff(), 1e-3) << fit.value_sigma.transpose();
  EXPECT_LT(fit.evaluations, 200);
  EXPECT_LT(fit.fitness, 1e-3 * problem.fitness(Eigen::VectorXd::Zero(4)));
}

// The reference optimum's starts run in lock-step, one batch a round. Each start must
// follow its own fit exactly: the starts below need different numbers of iterations and trials,
// so rounds mix one start's Jacobian with another's trials, and some starts finish early.
TEST(Identification, LocalFitsInLockStepEqualEachFitAlone) {
  const InsIdentificationProblem problem(static_problem(),
                                         ParameterMapping(EstimatedParameter::paper_four()));
  const std::vector<Eigen::VectorXd> x0s = {
      Eigen::VectorXd::Zero(4), Eigen::Vector4d(0.7, -0.6, 0.2, 0.9),
      Eigen::Vector4d(-0.5, 0.375, 0.5, -0.375), Eigen::Vector4d(-0.9, 0.9, -0.9, 0.9)};
  LocalFitOptions options;
  options.max_iterations = 12;
  options.tolerance_sigma = 1e-5;  // the starts stop after 1, 4 and 5 iterations here
  for (int threads : {1, 2}) {
    const std::vector<LocalFitResult> together = local_fits(problem, x0s, options, threads);
    ASSERT_EQ(together.size(), x0s.size());
    std::set<std::pair<std::int64_t, int>> shapes;
    for (std::size_t i = 0; i < x0s.size(); ++i) {
      const LocalFitResult alone = local_fit(problem, x0s[i], options);
      const LocalFitResult& t = together[i];
      EXPECT_EQ(t.value_sigma, alone.value_sigma) << "start " << i << ", " << threads << " threads";
      EXPECT_EQ(t.fitness, alone.fitness) << "start " << i;
      EXPECT_EQ(t.sum_squares, alone.sum_squares) << "start " << i;
      EXPECT_EQ(t.evaluations, alone.evaluations) << "start " << i;
      EXPECT_EQ(t.iterations, alone.iterations) << "start " << i;
      EXPECT_EQ(t.residuals, alone.residuals) << "start " << i;
      ASSERT_EQ(t.jacobian_sigma.rows(), alone.jacobian_sigma.rows()) << "start " << i;
      EXPECT_EQ(t.jacobian_sigma, alone.jacobian_sigma) << "start " << i;
      shapes.insert({alone.evaluations, alone.iterations});
    }
    // The starts did not march in step on their own (else nothing was interleaved).
    EXPECT_GE(shapes.size(), 3u) << [&] {
      std::string list;
      for (const auto& [e, it] : shapes) list += std::to_string(e) + "/" + std::to_string(it) + " ";
      return list;
    }();
  }
  // Without the Jacobian the estimate is the same.
  LocalFitOptions lean = options;
  lean.keep_jacobian = false;
  const LocalFitResult without = local_fit(problem, x0s[1], lean);
  EXPECT_EQ(without.jacobian_sigma.size(), 0);
  EXPECT_EQ(without.value_sigma, local_fit(problem, x0s[1], options).value_sigma);
  EXPECT_THROW(local_fits(problem, x0s, options, 0), std::invalid_argument);
}

TEST(Identification, LocalFitOptionsAreValidatedBeforeAnyRunNamingTheBadValue) {
  const InsIdentificationProblem problem(static_problem(),
                                         ParameterMapping(EstimatedParameter::paper_four()));
  EXPECT_EQ(LocalFitOptions{}.validate(), "");
  const auto error_of = [&](const LocalFitOptions& options) -> std::string {
    try {
      local_fit(problem, Eigen::VectorXd::Zero(4), options);
    } catch (const std::invalid_argument& e) {
      return e.what();
    }
    return "";
  };
  LocalFitOptions bad;
  bad.max_iterations = -1;
  EXPECT_EQ(error_of(bad), "local fit: max_iterations must be >= 0, got -1");
  bad = {};
  bad.step_sigma = 0.0;
  EXPECT_NE(error_of(bad).find("step_sigma must be a positive finite number"), std::string::npos);
  bad = {};
  bad.tolerance_sigma = -1e-6;
  EXPECT_NE(error_of(bad).find("tolerance_sigma must be a non-negative finite number"),
            std::string::npos);
}

// Static data with biases `scale` x the paper's after the alignment window, in `dir`.
std::shared_ptr<const NavigationProblem> write_static_data(const std::filesystem::path& dir,
                                                           double scale) {
  Dataset ds = test::make_static_dataset(EarthModel::paper(kLat, 50.0), kLat, 2.0, 50.0,
                                         {0.0, 0.0, 0.7}, 900.0, 300.0);
  SensorErrors errors = test::paper_errors();
  errors.gyro.bias *= scale;
  errors.accel.bias *= scale;
  for (ImuSample& s : ds.imu)
    if (s.t_s > 300.0 + 1e-9) apply_imu_errors(errors, 0.0, 0.01, s.dtheta_b_rad, s.dv_b_mps);
  write_dataset(dir, ds);
  return std::make_shared<const NavigationProblem>(
      std::make_shared<const Dataset>(load_dataset(dir)), NavigationOptions{AlignmentMode::kFixed});
}

// The campaign finds the optimum with its starts on several threads; the optimum must
// not depend on how many (start points drawn in order, best taken in start order).
TEST(Identification, ReferenceOptimumIsTheSameForAnyThreadCount) {
  const std::filesystem::path dir = test::fresh_dir("optimum-threads");
  const ParameterMapping mapping(EstimatedParameter::paper_four());
  const InsIdentificationProblem problem(write_static_data(dir, 1.0), mapping);
  const ReferenceOptimum one = find_reference_optimum(problem, 4, kReferenceOptimumSeed, 1);
  for (int threads : {2, 3, 4, 8}) {
    const ReferenceOptimum many =
        find_reference_optimum(problem, 4, kReferenceOptimumSeed, threads);
    EXPECT_EQ(many.fitness, one.fitness) << threads << " threads";
    EXPECT_EQ(many.value_sigma, one.value_sigma) << threads << " threads";
    EXPECT_EQ(many.evaluations, one.evaluations) << threads << " threads";
    EXPECT_EQ(many.starts, 4);
  }
  // The starts differ (else the test could not see a start lost or repeated).
  const ReferenceOptimum first_only = find_reference_optimum(problem, 1, kReferenceOptimumSeed, 1);
  EXPECT_NE(first_only.evaluations, one.evaluations);
  std::filesystem::remove_all(dir);
}

TEST(Identification, OptimumCacheFollowsTheDataNotTheDirectory) {
  const std::filesystem::path dir = test::fresh_dir("cache-test");
  const ParameterMapping mapping(EstimatedParameter::paper_four());
  const InsIdentificationProblem first(write_static_data(dir, 1.0), mapping);
  const ReferenceOptimum a = cached_reference_optimum(dir.string(), first);
  ASSERT_TRUE(std::filesystem::exists(dir / "insid-optimum-cache.json"));
  EXPECT_EQ(cached_reference_optimum(dir.string(), first).fitness, a.fitness);  // from the cache
  // The data in the directory are replaced by a flight with other biases (the cache stays).
  std::filesystem::copy_file(dir / "insid-optimum-cache.json", dir.string() + "-cache.json");
  const InsIdentificationProblem second(write_static_data(dir, 0.5), mapping);
  std::filesystem::copy_file(dir.string() + "-cache.json", dir / "insid-optimum-cache.json");
  const ReferenceOptimum b = cached_reference_optimum(dir.string(), second);
  const ReferenceOptimum fresh = find_reference_optimum(second);
  EXPECT_EQ(b.fitness, fresh.fitness);
  EXPECT_EQ(b.value_sigma, fresh.value_sigma);
  EXPECT_GT((b.value_sigma - a.value_sigma).cwiseAbs().maxCoeff(), 0.5)
      << a.value_sigma.transpose() << " vs " << b.value_sigma.transpose();
  std::filesystem::remove_all(dir);
  std::filesystem::remove(dir.string() + "-cache.json");
}

TEST(Identification, NonFiniteFitnessNamesTheCandidateInSiAndWhereItsNavigationBroke) {
  // One sigma of 1e200 m/s^2: the candidate at the box corner overflows; both evaluators refuse.
  // (Built directly: `--estimate accel_bias_x:1e200` is refused up front, and
  // this tests the evaluators' own guard, which any other overflow reaches.)
  EstimatedParameter huge = EstimatedParameter::parse("accel_bias_x");
  huge.sigma = 1e200;
  const ParameterMapping m({huge, EstimatedParameter::parse("gyro_bias_y")});
  const std::vector<Eigen::VectorXd> xs = {Eigen::Vector2d(0.0, 0.1), Eigen::Vector2d(1.0, 0.5)};
  for (const FitnessEvaluator implementation :
       {FitnessEvaluator::kBatched, FitnessEvaluator::kScalar}) {
    const InsIdentificationProblem problem(static_problem(), m, FitnessKind::kEq15, {},
                                           implementation);
    std::vector<double> f(2);
    try {
      problem.evaluate_batch(xs, f);
      ADD_FAILURE() << "no error for an overflowing candidate";
    } catch (const opt::NonFiniteFitnessError& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find("of candidate 1 (accel_bias_x = 4e+200 (4 sigma), gyro_bias_y = "),
                std::string::npos)
          << msg;
      EXPECT_NE(msg.find("non-finite"), std::string::npos) << msg;
    }
  }
}

TEST(Identification, ScalarResidualPathScoresAsTheFitnessBitForBit) {
  // The least-squares path (residuals + their sum) and the fitness path give the same bits, for
  // both fitness kinds (one sum of residuals, nav/fitness.h fitness_from_residuals).
  const ParameterMapping m(EstimatedParameter::paper_four());
  const std::vector<Eigen::VectorXd> xs = {Eigen::Vector4d(-0.5, 0.4, 0.5, -0.4),
                                           Eigen::Vector4d(0.1, -0.2, 0.3, 0.9)};
  for (FitnessKind kind : {FitnessKind::kEq15, FitnessKind::kSumSquares}) {
    const InsIdentificationProblem problem(static_problem(), m, kind, {},
                                           FitnessEvaluator::kScalar);
    std::vector<std::vector<double>> r(xs.size());
    std::vector<double> f(xs.size());
    problem.evaluate_residual_batch(xs, r, f);
    for (std::size_t i = 0; i < xs.size(); ++i)
      EXPECT_EQ(f[i], problem.navigation().fitness(m.to_errors(xs[i]), kind)) << i;
  }
}

TEST(Identification, SerialAndOpenMpEvaluationAgreeBitForBit) {
  const ParameterMapping m(EstimatedParameter::paper_four());
  opt::EvaluatorOptions serial, parallel;
  parallel.parallelism = opt::Parallelism::kOpenMP;
  parallel.num_threads = 2;
  const InsIdentificationProblem a(static_problem(), m, FitnessKind::kEq15, serial);
  const InsIdentificationProblem b(static_problem(), m, FitnessKind::kEq15, parallel);
  opt::RunConfig config;
  config.seed = 9;
  config.max_iterations = 4;
  const opt::Result ra = opt::optimize("dvpio", a, config);
  const opt::Result rb = opt::optimize("dvpio", b, config);
  EXPECT_EQ(ra.best_per_evaluation, rb.best_per_evaluation);
  EXPECT_EQ(ra.best_x, rb.best_x);
}

TEST(Identification, ResultJsonHasEstimatesErrorsAndHistory) {
  const ParameterMapping m(EstimatedParameter::paper_four());
  const InsIdentificationProblem problem(static_problem(), m);
  opt::RunConfig config;
  config.max_iterations = 3;
  const opt::Result r = opt::optimize("pso", problem, config);
  nlohmann::json j = optimizer_result_json(r, m);
  add_estimate_json(j, m, m.to_sigma(r.best_x), nonzero_effects(test::paper_errors()));
  EXPECT_EQ(j["history"].size(), 3u);
  EXPECT_EQ(j["best_per_evaluation"].size(), 30u);
  EXPECT_NEAR(j["truth_sigma"]["gyro_bias_x"].get<double>(), 2.0, 1e-12);
  EXPECT_NEAR(j["error_sigma"]["accel_bias_y"].get<double>(),
              j["estimate_in_sigma_units"]["accel_bias_y"].get<double>() - 1.5, 1e-12);
  EXPECT_NEAR(j["estimate"]["gyro_bias_y"].get<double>(),
              j["estimate_in_sigma_units"]["gyro_bias_y"].get<double>() * kSigmaGyroRadS, 1e-20);
  EXPECT_FALSE(j.contains("estimate_sigma"));  // renamed: it read as an sd
}

// GIVEN an IdentifySpec with one bad field WHEN validated THEN validate() says what is wrong and
// spec_problem names that field (field()) and its value (what()), before any data is read; a good
// spec passes.
TEST(Identification, IdentifySpecValidateNamesTheBadFieldAndValue) {
  IdentifySpec good;
  good.data_dir = "/nonexistent/never-read";  // validate() reads nothing
  EXPECT_EQ(good.validate(), "");
  EXPECT_FALSE(spec_problem(good));

  struct Case {
    const char* field;
    std::function<void(IdentifySpec&)> spoil;
    std::vector<std::string> said;  // in what(), besides the field
  };
  const std::vector<Case> cases = {
      {"data_dir", [](IdentifySpec& s) { s.data_dir.clear(); }, {"no dataset"}},
      {"algorithm",
       [](IdentifySpec& s) { s.algorithm = "nosuch"; },
       {"unknown optimizer 'nosuch'"}},
      {"grade", [](IdentifySpec& s) { s.grade = "consumer"; }, {"'consumer'"}},
      {"estimate", [](IdentifySpec& s) { s.estimate = {"gyro_bias_q"}; }, {"gyro_bias_q"}},
      {"estimate",
       [](IdentifySpec& s) { s.estimate = {"gyro_bias_x:1e-7:1:-1"}; },
       {"LO must be < HI"}},
      {"params", [](IdentifySpec& s) { s.params = {"w"}; }, {"KEY=VALUE", "'w'"}},
      {"params", [](IdentifySpec& s) { s.params = {"w=inf"}; }, {"w", "'inf'"}},
      {"iterations", [](IdentifySpec& s) { s.iterations = -1; }, {"-1"}},
      {"evaluations", [](IdentifySpec& s) { s.evaluations = -5; }, {"-5"}},
      {"iterations", [](IdentifySpec& s) { s.iterations = 0; }, {"evaluations 0", "no budget"}},
      {"window_s", [](IdentifySpec& s) { s.window_s = -2.0; }, {"-2"}},
      {"threads", [](IdentifySpec& s) { s.threads = -3; }, {"-3"}},
      {"uncertainty_replicas", [](IdentifySpec& s) { s.uncertainty_replicas = 5; }, {"5"}},
      {"initial_attitude",
       [](IdentifySpec& s) { s.initial_attitude.course_min_speed_mps = -1.0; },
       {"course_min_speed_mps"}}};
  for (const Case& c : cases) {
    IdentifySpec spec = good;
    c.spoil(spec);
    const std::optional<IdentifySpecError> problem = spec_problem(spec);
    if (!problem) {
      ADD_FAILURE() << c.field << ": no error";
      continue;
    }
    const std::string what = problem->what();
    EXPECT_EQ(spec.validate(), what);
    EXPECT_EQ(problem->field(), c.field) << what;
    for (const std::string& s : c.said) EXPECT_NE(what.find(s), std::string::npos) << what;
  }
  // A dataset given in memory needs no directory.
  IdentifySpec in_memory;
  in_memory.dataset = std::make_shared<const Dataset>(static_problem()->dataset());
  EXPECT_EQ(in_memory.validate(), "");
}

// The default set and the allowance rule (identification/identify.h): nav the paper's four and
// 4 catalogue sigmas of the x/y gyro bias; mems five biases and 4 x 0.1 deg/s; no horizontal
// gyro bias estimated: the catalogue sigma.
TEST(Identification, DefaultSetAndGyroBiasAllowanceFollowTheGradeAndTheBox) {
  const std::vector<EstimatedParameter> nav = identify_parameters(sensor_grade("nav"), {});
  ASSERT_EQ(nav.size(), 4u);
  EXPECT_DOUBLE_EQ(gyro_bias_allowance_rad_s(nav), 4.0 * kSigmaGyroRadS);
  const std::vector<EstimatedParameter> mems = identify_parameters(sensor_grade("mems"), {});
  ASSERT_EQ(mems.size(), 5u);
  EXPECT_EQ(mems[4].name, "gyro_bias_z");
  EXPECT_DOUBLE_EQ(gyro_bias_allowance_rad_s(mems), 4.0 * 0.1 * kDegToRad);
  // A wider box on gyro_bias_y alone counts; gyro_bias_z does not (it does not tilt the
  // gyrocompass heading).
  const std::vector<EstimatedParameter> wide = identify_parameters(
      sensor_grade("nav"), {"gyro_bias_x", "gyro_bias_y:1e-6:-2:7", "gyro_bias_z:1:-4:4"});
  EXPECT_DOUBLE_EQ(gyro_bias_allowance_rad_s(wide), 7e-6);
  EXPECT_DOUBLE_EQ(
      gyro_bias_allowance_rad_s(identify_parameters(sensor_grade("nav"), {"accel_bias_x"})),
      InitialAttitudeOptions{}.gyro_bias_allowance_rad_s);
}

}  // namespace
}  // namespace insid
