// Reference baselines on INS data: the EKF-RTS bias estimates against the injected
// values on a `rich` flight, and every generic baseline (pagmo CMA-ES / DE / compass, NLopt
// BOBYQA / Nelder-Mead, Ceres LM) on a short noise-free flight at a documented accuracy, with
// evaluation counts checked against the problem's own counter.
#include <atomic>
#include <chrono>
#include <cmath>
#include <iostream>
#include <memory>

#include <gtest/gtest.h>

#include "identification/ekf_rts.h"
#include "identification/identify.h"
#include "identification/ins_problem.h"
#include "optimizers/registry.h"
#include "scenarios/scenario.h"
#include "test_support/test_support.h"

namespace insid {
namespace {

// Counting decorator around the INS problem: every fitness or residual evaluation (one full
// INS run each).
class CountingInsProblem final : public opt::Problem, public opt::ResidualProblem {
 public:
  explicit CountingInsProblem(const InsIdentificationProblem& inner)
      : opt::Problem(inner.bounds()), inner_(inner) {}
  int residual_count() const override { return inner_.residual_count(); }
  void evaluate_batch(std::span<const Eigen::VectorXd> xs, std::span<double> f) const override {
    count_ += static_cast<std::int64_t>(xs.size());
    inner_.evaluate_batch(xs, f);
  }
  void evaluate_residual_batch(std::span<const Eigen::VectorXd> xs,
                               std::span<std::vector<double>> r,
                               std::span<double> f) const override {
    count_ += static_cast<std::int64_t>(xs.size());
    inner_.evaluate_residual_batch(xs, r, f);
  }
  std::int64_t count() const { return count_; }

 private:
  const InsIdentificationProblem& inner_;
  mutable std::atomic<std::int64_t> count_{0};
};

TEST(EkfRts, BiasEstimatesConvergeToTheInjectedValuesWithinThreeSigma) {
  const auto dataset = test::simulate_preset("rich", 2700.0, "nav", 7);
  const NavigationProblem navigation(dataset);
  const EkfRtsResult r = run_ekf_rts(navigation);
  const auto& injected = *dataset->meta.injected;
  for (const auto& [name, value] : r.estimate) {
    const auto it = injected.find(name);
    const double truth = it == injected.end() ? 0.0 : it->second;
    const double sigma = effect_info(name).sigma;
    std::cout << "[ ekf-rts ] " << name << ": estimate " << value / sigma << " sigma, truth "
              << truth / sigma << ", std " << r.std.at(name) / sigma << " (filtered "
              << r.filtered_estimate.at(name) / sigma << ")\n";
    EXPECT_LE(std::abs(value - truth), 3.0 * r.std.at(name)) << name;
    EXPECT_GT(r.std.at(name), 0.0);
  }
  // The horizontal biases the paper identifies are well determined on this flight.
  for (const char* name : {"accel_bias_x", "accel_bias_y", "gyro_bias_x", "gyro_bias_y"})
    EXPECT_LT(r.std.at(name) / effect_info(name).sigma, 1.0) << name;
  std::cout << "[ ekf-rts ] " << r.updates << " updates, filter " << r.filter_wall_s
            << " s, smoother " << r.smoother_wall_s << " s\n";
}

TEST(EkfRts, RunsAsARegisteredAlgorithmWithOneEvaluation) {
  const auto dataset = test::simulate_preset("rich", 900.0, "none", 1);
  const auto navigation = std::make_shared<const NavigationProblem>(dataset);
  const InsIdentificationProblem problem(navigation,
                                         ParameterMapping(EstimatedParameter::paper_four()));
  opt::RunConfig config;
  config.max_iterations = 0;
  config.max_evaluations = 400;
  auto optimizer = opt::make_optimizer("ekf-rts", problem.bounds(), config);
  const opt::Result& result = opt::run(*optimizer, problem);
  EXPECT_EQ(result.evaluations, 1);
  EXPECT_EQ(result.iterations, 1);
  const auto& ekf = dynamic_cast<const EkfRtsOptimizer&>(*optimizer);
  EXPECT_GT(ekf.equivalent_ins_runs(), 0.0);
  const Eigen::VectorXd truth = Eigen::Vector4d(-2, 1.5, 2, -1.5);
  const Eigen::VectorXd err = problem.mapping().to_sigma(result.best_x) - truth;
  std::cout << "[ ekf-rts ] noise-free 900 s: error " << err.transpose() << " sigma, std "
            << ekf.std_sigma().transpose() << ", " << ekf.equivalent_ins_runs() << " INS runs\n";
  for (int k = 0; k < 4; ++k) EXPECT_LE(std::abs(err[k]), 3.0 * ekf.std_sigma()[k] + 0.05);
  // Its registry traits say what it does: it takes the problem itself, and the seed does not
  // change its answer.
  const opt::AlgorithmTraits traits = opt::algorithm_traits("ekf-rts");
  EXPECT_EQ(traits.needs_problem, dynamic_cast<opt::ProblemConsumer*>(optimizer.get()) != nullptr);
  EXPECT_EQ(traits.needs_residuals,
            dynamic_cast<opt::ResidualConsumer*>(optimizer.get()) != nullptr);
  ASSERT_FALSE(traits.stochastic);
  opt::RunConfig other_seed = config;
  other_seed.seed = config.seed + 1;
  EXPECT_EQ(opt::optimize("ekf-rts", problem, other_seed).best_x, result.best_x);
  // Other problems are refused with a clear message.
  const auto sphere = opt::FunctionProblem(
      opt::Bounds::unit_box(4), [](const Eigen::VectorXd& x) { return x.squaredNorm(); });
  EXPECT_THROW(opt::optimize("ekf-rts", sphere, config), std::invalid_argument);
}

// The grade the caller settled reaches the filter's set-up as it is; without one the filter takes
// the dataset's own (grade_for: nav for a simulated flight without a noise block, which with
// gyrocompassing needs no grade set-up: "").
TEST(EkfRts, UsesTheGradeItIsGivenElseTheDatasets) {
  const auto dataset = test::simulate_preset("rich", 300.0, "none", 1);
  const auto navigation = std::make_shared<const NavigationProblem>(dataset);
  const InsIdentificationProblem problem(navigation,
                                         ParameterMapping(EstimatedParameter::paper_four()));
  opt::RunConfig config;
  config.max_iterations = 0;
  config.max_evaluations = 10;
  const auto setup_grade = [&](const SensorGrade* grade) {
    EkfRtsOptimizer ekf(problem.bounds(), config);
    if (grade) ekf.set_grade(*grade);
    opt::run(ekf, problem);
    const nlohmann::json j = ekf.ekf()->to_json();
    return j.contains("setup") ? j["setup"]["grade"].get<std::string>() : std::string();
  };
  EXPECT_EQ(setup_grade(nullptr), "");
  EXPECT_EQ(setup_grade(&sensor_grade("nav")), "");
  EXPECT_EQ(setup_grade(&sensor_grade("tactical")), "tactical");
}

// Each generic baseline on a short noise-free `rich` flight: the estimate's largest error
// against the injected values (sigma units) at a fixed budget, and exact evaluation counts.
TEST(Baselines, ReachTheDocumentedAccuracyOnNoiseFreeInsData) {
  const auto dataset = test::simulate_preset("rich", 300.0, "none", 1);
  const auto navigation = std::make_shared<const NavigationProblem>(dataset);
  opt::EvaluatorOptions evaluator;
  evaluator.parallelism = opt::Parallelism::kOpenMP;
  const InsIdentificationProblem problem(navigation,
                                         ParameterMapping(EstimatedParameter::paper_four()),
                                         FitnessKind::kEq15, evaluator);
  const Eigen::VectorXd truth = Eigen::Vector4d(-2, 1.5, 2, -1.5);
  struct Case {
    std::string name;
    std::int64_t evaluations;
    double max_error_sigma;
  };
  // Thresholds: identification/README.md (measured value x ~3; compass stalls in the
  // per-candidate alignment's narrow valley: the ablation of DVPIO's axis probing).
  const std::vector<Case> cases = {{"lm", 60, 2e-3},      {"bobyqa", 200, 0.1},
                                   {"cmaes", 600, 0.1},   {"de", 600, 0.3},
                                   {"compass", 300, 2.0}, {"neldermead", 200, 2e-3}};
  for (const Case& c : cases) {
    CountingInsProblem counting(problem);
    opt::RunConfig config;
    config.seed = 3;
    config.max_iterations = 0;
    config.max_evaluations = c.evaluations;
    const auto t0 = std::chrono::steady_clock::now();
    const opt::Result result = opt::optimize(c.name, counting, config);
    const double wall =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const Eigen::VectorXd err = problem.mapping().to_sigma(result.best_x) - truth;
    const double max_err = err.cwiseAbs().maxCoeff();
    std::cout << "[ baseline ] " << c.name << " " << c.evaluations << " evaluations: max |error| "
              << max_err << " sigma, fitness " << result.best_f << ", " << wall << " s\n";
    EXPECT_EQ(result.evaluations, c.evaluations) << c.name;
    EXPECT_EQ(counting.count(), result.evaluations) << c.name;
    EXPECT_LE(max_err, c.max_error_sigma) << c.name;
  }
}

}  // namespace
}  // namespace insid
