// Reference baselines (pagmo CMA-ES / DE / compass, NLopt BOBYQA / Nelder-Mead, Ceres LM):
// accuracy on test functions at fixed budgets, exact evaluation accounting against a counting
// problem, budgets, determinism, the box, and stopping a run whose solver thread is waiting.
#include <atomic>
#include <cmath>
#include <memory>

#include <gtest/gtest.h>

#include "optimizers/registry.h"
#include "optimizers/test_functions.h"
#include "test_support/optimizer_runs.h"

namespace insid::opt {
namespace {

// Residual form of the shifted sphere / Rosenbrock (least squares: f = sum r_i^2).
class LeastSquaresProblem final : public Problem, public ResidualProblem {
 public:
  LeastSquaresProblem(int n, bool rosenbrock)
      : Problem(Bounds::unit_box(n)), o_(benchmark_optimum(n)), rosenbrock_(rosenbrock) {}
  int residual_count() const override { return rosenbrock_ ? 2 * (dimension() - 1) : dimension(); }
  std::vector<double> residuals(const Eigen::VectorXd& x) const {
    std::vector<double> r;
    if (!rosenbrock_) {
      for (int j = 0; j < dimension(); ++j) r.push_back(x[j] - o_[j]);
    } else {
      const Eigen::VectorXd z = 2.048 * (x - o_) + Eigen::VectorXd::Ones(dimension());
      for (int j = 0; j + 1 < dimension(); ++j) {
        r.push_back(10.0 * (z[j + 1] - z[j] * z[j]));
        r.push_back(1.0 - z[j]);
      }
    }
    return r;
  }
  static double sum_squares(const std::vector<double>& r) {
    double s = 0.0;
    for (double v : r) s += v * v;
    return s;
  }
  void evaluate_batch(std::span<const Eigen::VectorXd> xs, std::span<double> f) const override {
    for (std::size_t i = 0; i < xs.size(); ++i) f[i] = sum_squares(residuals(xs[i]));
  }
  void evaluate_residual_batch(std::span<const Eigen::VectorXd> xs,
                               std::span<std::vector<double>> r,
                               std::span<double> f) const override {
    for (std::size_t i = 0; i < xs.size(); ++i) {
      r[i] = residuals(xs[i]);
      f[i] = sum_squares(r[i]);
    }
  }

 private:
  Eigen::VectorXd o_;
  bool rosenbrock_;
};

// Counting decorator: every fitness or residual evaluation of the inner problem, and whether
// every point lay in the box.
class CountingProblem final : public Problem, public ResidualProblem {
 public:
  explicit CountingProblem(const LeastSquaresProblem& inner)
      : Problem(inner.bounds()), inner_(inner) {}
  int residual_count() const override { return inner_.residual_count(); }
  void evaluate_batch(std::span<const Eigen::VectorXd> xs, std::span<double> f) const override {
    note(xs);
    inner_.evaluate_batch(xs, f);
  }
  void evaluate_residual_batch(std::span<const Eigen::VectorXd> xs,
                               std::span<std::vector<double>> r,
                               std::span<double> f) const override {
    note(xs);
    inner_.evaluate_residual_batch(xs, r, f);
  }
  std::int64_t count() const { return count_; }
  bool all_in_box() const { return all_in_box_; }

 private:
  void note(std::span<const Eigen::VectorXd> xs) const {
    count_ += static_cast<std::int64_t>(xs.size());
    for (const Eigen::VectorXd& x : xs) all_in_box_ = all_in_box_ && bounds().contains(x);
  }
  const LeastSquaresProblem& inner_;
  mutable std::atomic<std::int64_t> count_{0};
  mutable std::atomic<bool> all_in_box_{true};
};

RunConfig budget(std::int64_t evaluations, std::uint64_t seed) {
  RunConfig config;
  config.seed = seed;
  config.max_iterations = 0;
  config.max_evaluations = evaluations;
  return config;
}

TEST(Baselines, AreRegisteredWithDefaults) {
  for (const std::string& name : baseline_algorithm_names()) {
    SCOPED_TRACE(name);
    EXPECT_EQ(make_optimizer(name, Bounds::unit_box(4), budget(10, 1))->parameters(),
              default_parameters(name));
  }
  EXPECT_THROW(make_optimizer("cmaes", Bounds::unit_box(4), budget(10, 1), {{"population", 4}}),
               std::invalid_argument);
  EXPECT_THROW(make_optimizer("de", Bounds::unit_box(4), budget(10, 1), {{"variant", 11}}),
               std::invalid_argument);
  EXPECT_THROW(make_optimizer("lm", Bounds::unit_box(4), budget(10, 1), {{"fd_step", 0}}),
               std::invalid_argument);
}

// Exact accounting: the run's evaluation count, the trace and the history agree with the
// problem's own counter, every candidate is in the box, the budget is used exactly.
TEST(Baselines, EvaluationCountsAgreeWithTheProblemsCounter) {
  const LeastSquaresProblem sphere(4, false);
  for (const std::string& name : baseline_algorithm_names()) {
    for (const std::int64_t evaluations : {1, 7, 95, 400}) {
      SCOPED_TRACE(name + " budget " + std::to_string(evaluations));
      CountingProblem counting(sphere);
      const Result result = optimize(name, counting, budget(evaluations, 3));
      EXPECT_EQ(result.evaluations, evaluations);
      EXPECT_EQ(counting.count(), result.evaluations);
      EXPECT_EQ(static_cast<std::int64_t>(result.best_per_evaluation.size()), evaluations);
      EXPECT_EQ(result.history.back().evaluations, evaluations);
      EXPECT_EQ(result.termination, Termination::kEvaluations);
      EXPECT_TRUE(counting.all_in_box());
      std::int64_t sum = 0;
      for (const IterationRecord& record : result.history) sum += record.batch_size;
      EXPECT_EQ(sum, evaluations);
    }
  }
}

TEST(Baselines, GenerationsArePagmosBatches) {
  const LeastSquaresProblem sphere(4, false);
  RunConfig config;
  config.max_iterations = 5;
  for (const std::string name : {"cmaes", "de"}) {
    const Result result = optimize(name, sphere, config);
    ASSERT_EQ(result.history.size(), 5u);
    EXPECT_EQ(result.history[0].phase, "initial");
    for (const IterationRecord& record : result.history) EXPECT_EQ(record.batch_size, 10);
    EXPECT_EQ(result.history[1].phase, "generation");
  }
  // LM: the start point alone, then Jacobians of n columns (base point reused) and trial steps.
  const Result lm = optimize("lm", sphere, config);
  EXPECT_EQ(lm.history[0].batch_size, 1);
  EXPECT_EQ(lm.history[1].batch_size, 4);
  EXPECT_EQ(lm.history[1].phase, "jacobian");
  EXPECT_EQ(lm.history[2].phase, "jacobian");  // bounded: Ceres's line search needs the gradient
}

TEST(Baselines, SameSeedSameRunAndRunTogetherEqualsSeparateRuns) {
  const LeastSquaresProblem rosenbrock(4, true);
  for (const std::string& name : baseline_algorithm_names()) {
    SCOPED_TRACE(name);
    const Result a = optimize(name, rosenbrock, budget(300, 11));
    const Result b = optimize(name, rosenbrock, budget(300, 11));
    test::expect_same_run(a, b);
    const Result c = optimize(name, rosenbrock, budget(300, 12));
    EXPECT_NE(a.best_per_evaluation, c.best_per_evaluation);
  }
  std::vector<std::unique_ptr<Optimizer>> owned;
  std::vector<Optimizer*> raw;
  for (const std::string& name : baseline_algorithm_names()) {
    owned.push_back(make_optimizer(name, rosenbrock.bounds(), budget(200, 5)));
    raw.push_back(owned.back().get());
  }
  run_together(raw, rosenbrock);
  for (std::size_t i = 0; i < owned.size(); ++i) {
    SCOPED_TRACE(baseline_algorithm_names()[i]);
    test::expect_same_run(owned[i]->result(),
                          optimize(baseline_algorithm_names()[i], rosenbrock, budget(200, 5)));
  }
}

// Counts the calls (not the candidates) of each kind of batch evaluation.
class CallCountingProblem final : public Problem, public ResidualProblem {
 public:
  explicit CallCountingProblem(const LeastSquaresProblem& inner)
      : Problem(inner.bounds()), inner_(inner) {}
  int residual_count() const override { return inner_.residual_count(); }
  void evaluate_batch(std::span<const Eigen::VectorXd> xs, std::span<double> f) const override {
    ++fitness_calls;
    inner_.evaluate_batch(xs, f);
  }
  void evaluate_residual_batch(std::span<const Eigen::VectorXd> xs,
                               std::span<std::vector<double>> r,
                               std::span<double> f) const override {
    ++residual_calls;
    inner_.evaluate_residual_batch(xs, r, f);
  }
  mutable int fitness_calls = 0, residual_calls = 0;

 private:
  const LeastSquaresProblem& inner_;
};

TEST(Baselines, RunTogetherScoresTheLeastSquaresRunsOfARoundInOneResidualCall) {
  // GIVEN three Levenberg-Marquardt runs (residual vectors) and a BOBYQA run in lock-step
  const LeastSquaresProblem rosenbrock(4, true);
  const CallCountingProblem problem(rosenbrock);
  const std::vector<std::pair<std::string, RunConfig>> specs = {{"lm", budget(60, 1)},
                                                                {"lm", budget(90, 2)},
                                                                {"lm", budget(40, 3)},
                                                                {"bobyqa", budget(50, 4)}};
  std::vector<std::unique_ptr<Optimizer>> owned;
  std::vector<Optimizer*> raw;
  for (const auto& [name, config] : specs) {
    owned.push_back(make_optimizer(name, rosenbrock.bounds(), config));
    raw.push_back(owned.back().get());
  }
  // WHEN advanced together
  run_together(raw, problem);
  // THEN each round's LM batches went to one evaluate_residual_batch call (as many calls as the
  // longest LM run has iterations), BOBYQA's to evaluate_batch, one call per iteration
  int longest_lm = 0;
  for (std::size_t i = 0; i < 3; ++i)
    longest_lm = std::max(longest_lm, raw[i]->result().iterations);
  EXPECT_EQ(problem.residual_calls, longest_lm);
  EXPECT_LT(longest_lm, raw[0]->result().iterations + raw[1]->result().iterations +
                            raw[2]->result().iterations);
  EXPECT_EQ(problem.fitness_calls, raw[3]->result().iterations);
  // AND every run equals its separate run
  for (std::size_t i = 0; i < specs.size(); ++i) {
    SCOPED_TRACE(specs[i].first + " run " + std::to_string(i));
    test::expect_same_run(raw[i]->result(), optimize(specs[i].first, rosenbrock, specs[i].second));
  }
}

// Documented accuracy (optimizers/README.md): median best fitness of 11 seeds at a fixed budget.
double median_best(const std::string& name, const Problem& problem, std::int64_t evaluations) {
  std::vector<double> best;
  for (std::uint64_t seed = 100; seed < 111; ++seed)
    best.push_back(optimize(name, problem, budget(evaluations, seed)).best_f);
  std::sort(best.begin(), best.end());
  return best[best.size() / 2];
}

TEST(Baselines, ReachTheDocumentedAccuracy) {
  const LeastSquaresProblem sphere(4, false);
  const LeastSquaresProblem rosenbrock(4, true);
  struct Case {
    std::string name;
    const Problem* problem;
    std::int64_t evaluations;
    double threshold;
  };
  const std::vector<Case> cases = {
      {"cmaes", &sphere, 400, 1e-5},        {"de", &sphere, 400, 1e-2},
      {"compass", &sphere, 400, 1e-12},     {"lm", &sphere, 50, 1e-20},
      {"bobyqa", &sphere, 100, 1e-12},      {"neldermead", &sphere, 400, 1e-15},
      {"cmaes", &rosenbrock, 2000, 1e-8},   {"lm", &rosenbrock, 400, 1e-20},
      {"bobyqa", &rosenbrock, 1000, 1e-12},
  };
  for (const Case& c : cases) {
    const double median = median_best(c.name, *c.problem, c.evaluations);
    std::cout << "[ baseline ] " << c.name << " "
              << (c.problem == &sphere ? "sphere" : "rosenbrock") << " " << c.evaluations
              << " evaluations: median best " << median << "\n";
    EXPECT_LE(median, c.threshold) << c.name;
  }
}

TEST(Baselines, LmWithoutResidualsIsAClearError) {
  const auto sphere = make_benchmark("sphere", 4);
  EXPECT_THROW(optimize("lm", *sphere, budget(20, 1)), std::invalid_argument);
  // A hand-written ask / evaluate_batch / tell loop gives no residuals: tell() says so.
  auto lm = make_optimizer("lm", sphere->bounds(), budget(20, 1));
  const auto batch = lm->ask();
  std::vector<double> f(batch.size());
  sphere->evaluate_batch(batch, f);
  EXPECT_THROW(lm->tell(f), std::logic_error);
}

TEST(Baselines, DestroyingARunWhoseSolverWaitsReturns) {
  const LeastSquaresProblem sphere(4, false);
  for (const std::string& name : baseline_algorithm_names()) {
    auto optimizer = make_optimizer(name, sphere.bounds(), budget(1000, 1));
    for (int k = 0; k < 3; ++k) step(*optimizer, sphere);
    (void)optimizer->ask();  // solver waiting for values
    optimizer.reset();       // must not hang
  }
}

}  // namespace
}  // namespace insid::opt
