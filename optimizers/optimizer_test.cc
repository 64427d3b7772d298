// Properties every optimizer must have: reproducible from the seed, independent of the
// evaluator (serial / OpenMP, 1 or 2 threads, shared batches), budgets respected, errors
// reported.
#include "optimizers/optimizer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <tuple>
#include <vector>

#include <gtest/gtest.h>

#include "optimizers/pio.h"
#include "optimizers/registry.h"
#include "optimizers/test_functions.h"
#include "test_support/optimizer_runs.h"

namespace insid::opt {
namespace {

RunConfig config_with(std::uint64_t seed, int iterations, std::int64_t evaluations = 0) {
  RunConfig config;
  config.seed = seed;
  config.max_iterations = iterations;
  config.max_evaluations = evaluations;
  config.record_positions = true;
  return config;
}

class EveryOptimizer : public ::testing::TestWithParam<std::string> {};

TEST_P(EveryOptimizer, SameSeedSameRunDifferentSeedDifferentRun) {
  const auto problem = make_benchmark("rastrigin", 4);
  const Result a = optimize(GetParam(), *problem, config_with(5, 60));
  const Result b = optimize(GetParam(), *problem, config_with(5, 60));
  const Result c = optimize(GetParam(), *problem, config_with(6, 60));
  test::expect_same_run(a, b);
  EXPECT_NE(a.best_per_evaluation, c.best_per_evaluation);
  EXPECT_FALSE(test::same(a.best_x, c.best_x));
}

TEST_P(EveryOptimizer, SerialAndOpenMPEvaluatorsGiveBitIdenticalRuns) {
  const RunConfig config = config_with(9, 50);
  const auto serial = make_benchmark("rosenbrock", 5, {Parallelism::kSerial, 0});
  const auto one = make_benchmark("rosenbrock", 5, {Parallelism::kOpenMP, 1});
  const auto two = make_benchmark("rosenbrock", 5, {Parallelism::kOpenMP, 2});
  const Result reference = optimize(GetParam(), *serial, config);
  test::expect_same_run(reference, optimize(GetParam(), *one, config));
  test::expect_same_run(reference, optimize(GetParam(), *two, config));
}

TEST_P(EveryOptimizer, SharedBatchesGiveTheSameRunsAsSeparateRuns) {
  // GIVEN three runs (two seeds, two budgets) WHEN advanced together with one evaluate_batch per
  // round THEN each equals its separate run.
  const auto problem = make_benchmark("sphere", 3, {Parallelism::kOpenMP, 2});
  const std::vector<RunConfig> configs = {config_with(1, 30), config_with(2, 0, 137),
                                          config_with(3, 12)};
  std::vector<std::unique_ptr<Optimizer>> owners;
  std::vector<Optimizer*> together;
  for (const RunConfig& config : configs) {
    owners.push_back(make_optimizer(GetParam(), problem->bounds(), config));
    together.push_back(owners.back().get());
  }
  run_together(together, *problem);
  for (std::size_t r = 0; r < configs.size(); ++r) {
    SCOPED_TRACE("run " + std::to_string(r));
    test::expect_same_run(together[r]->result(), optimize(GetParam(), *problem, configs[r]));
  }
}

TEST_P(EveryOptimizer, EvaluationBudgetIsNeverExceededAndTraceIsMonotone) {
  const auto problem = make_benchmark("rosenbrock", 4);
  for (const std::int64_t budget : {1, 7, 95, 400, 401, 1003}) {
    SCOPED_TRACE("budget " + std::to_string(budget));
    const Result result = optimize(GetParam(), *problem, config_with(3, 0, budget));
    EXPECT_EQ(result.evaluations, budget);
    EXPECT_EQ(result.termination, Termination::kEvaluations);
    ASSERT_EQ(static_cast<std::int64_t>(result.best_per_evaluation.size()), budget);
    EXPECT_TRUE(
        std::is_sorted(result.best_per_evaluation.rbegin(), result.best_per_evaluation.rend()));
    EXPECT_EQ(result.best_per_evaluation.back(), result.best_f);
    EXPECT_EQ(problem->fitness(result.best_x), result.best_f);
    EXPECT_EQ(result.history.back().evaluations, budget);
  }
}

TEST_P(EveryOptimizer, IterationBudgetAndWhicheverComesFirst) {
  const auto problem = make_benchmark("sphere", 4);
  const Result by_iterations = optimize(GetParam(), *problem, config_with(3, 40));
  EXPECT_EQ(by_iterations.iterations, 40);
  EXPECT_EQ(by_iterations.history.size(), 40u);
  EXPECT_EQ(by_iterations.termination, Termination::kIterations);
  const Result by_evaluations = optimize(GetParam(), *problem, config_with(3, 40, 55));
  EXPECT_EQ(by_evaluations.evaluations, 55);
  EXPECT_EQ(by_evaluations.termination, Termination::kEvaluations);
  // The run with the tighter budget is a prefix of the longer one.
  EXPECT_TRUE(std::equal(by_evaluations.best_per_evaluation.begin(),
                         by_evaluations.best_per_evaluation.end(),
                         by_iterations.best_per_evaluation.begin()));
}

TEST_P(EveryOptimizer, StopsAtTheTarget) {
  const auto problem = make_benchmark("sphere", 2);
  RunConfig config = config_with(4, 500);
  config.target_fitness = 1e-3;
  const Result result = optimize(GetParam(), *problem, config);
  EXPECT_EQ(result.termination, Termination::kTarget);
  EXPECT_LE(result.best_f, 1e-3);
  EXPECT_GT(result.history[result.history.size() - 2].best_fitness, 1e-3);
}

TEST_P(EveryOptimizer, HistoryIsConsistentAndCandidatesStayInTheBox) {
  const auto problem = make_benchmark("rastrigin", 3);
  const Result result = optimize(GetParam(), *problem, config_with(8, 45));
  std::int64_t evaluations = 0;
  for (std::size_t k = 0; k < result.history.size(); ++k) {
    const IterationRecord& record = result.history[k];
    evaluations += record.batch_size;
    EXPECT_EQ(record.iteration, static_cast<int>(k) + 1);
    EXPECT_EQ(record.evaluations, evaluations);
    EXPECT_EQ(record.best_fitness, result.best_per_evaluation[evaluations - 1]);
    EXPECT_EQ(record.phase.empty(), false);
    ASSERT_EQ(record.positions.size(), static_cast<std::size_t>(record.batch_size));
    ASSERT_EQ(record.fitness.size(), static_cast<std::size_t>(record.batch_size));
    std::vector<double> sorted = record.fitness;
    std::sort(sorted.begin(), sorted.end());
    EXPECT_GE(record.median_fitness, sorted.front());
    EXPECT_LE(record.median_fitness, sorted.back());
    for (std::size_t i = 0; i < record.positions.size(); ++i) {
      EXPECT_TRUE(problem->bounds().contains(record.positions[i]));
      EXPECT_EQ(record.fitness[i], problem->fitness(record.positions[i]));
    }
  }
  EXPECT_EQ(result.history.front().phase, "initial");
  EXPECT_EQ(evaluations, result.evaluations);
  EXPECT_GE(result.wall_time_s, 0.0);
  EXPECT_EQ(result.parameters, default_parameters(GetParam()));
}

TEST_P(EveryOptimizer, InitialPositionsAreUsed) {
  const auto problem = make_benchmark("sphere", 3);
  RunConfig config = config_with(2, 3);
  config.initial_positions = {benchmark_optimum(3), Eigen::Vector3d(0.5, 0.5, 0.5)};
  const Result result = optimize(GetParam(), *problem, config);
  EXPECT_TRUE(test::same(result.history[0].positions[0], benchmark_optimum(3)));
  EXPECT_TRUE(test::same(result.history[0].positions[1], Eigen::Vector3d(0.5, 0.5, 0.5)));
  EXPECT_EQ(result.best_per_evaluation[0], 0.0);
}

TEST_P(EveryOptimizer, NonFiniteFitnessIsAnErrorNamingTheCandidate) {
  const FunctionProblem problem(Bounds::unit_box(2), [](const Eigen::VectorXd& x) {
    return x[0] > 0.5 ? std::numeric_limits<double>::quiet_NaN() : x[0] * x[0] + x[1] * x[1];
  });
  RunConfig config = config_with(1, 10);
  config.initial_positions = {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(0.75, -0.5)};
  try {
    optimize(GetParam(), problem, config);
    FAIL() << "no exception";
  } catch (const NonFiniteFitnessError& e) {
    EXPECT_NE(std::string(e.what()).find("iteration 1: non-finite fitness nan for candidate 1 at "
                                         "x = [0.75, -0.5]"),
              std::string::npos)
        << e.what();
  }
}

TEST_P(EveryOptimizer, ExceptionInParallelEvaluationPropagates) {
  const FunctionProblem problem(Bounds::unit_box(2),
                                [](const Eigen::VectorXd& x) -> double {
                                  if (x[1] > 0.9)
                                    throw std::runtime_error("simulated kernel failure");
                                  return x[0] * x[0] + x[1] * x[1];
                                },
                                {Parallelism::kOpenMP, 2});
  RunConfig config = config_with(1, 20);
  config.initial_positions = {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(0.0, 0.95)};
  try {
    optimize(GetParam(), problem, config);
    FAIL() << "no exception";
  } catch (const EvaluationError& e) {
    EXPECT_NE(std::string(e.what()).find("candidate 1 at x = [0, 0.95]: simulated kernel failure"),
              std::string::npos)
        << e.what();
  }
}

INSTANTIATE_TEST_SUITE_P(Optimizers, EveryOptimizer, ::testing::Values("ga", "pso", "pio", "dvpio"),
                         [](const auto& param_info) { return param_info.param; });

TEST(AskTell, ProtocolIsChecked) {
  const auto problem = make_benchmark("sphere", 2);
  const auto optimizer = make_optimizer("pso", problem->bounds(), config_with(1, 2));
  EXPECT_THROW(optimizer->tell(std::vector<double>(10, 1.0)), std::logic_error);
  const auto batch = optimizer->ask();
  EXPECT_EQ(optimizer->ask().data(), batch.data());  // idempotent while pending
  EXPECT_THROW(optimizer->tell(std::vector<double>(3, 1.0)), std::invalid_argument);
  std::vector<double> f(batch.size(), std::numeric_limits<double>::infinity());
  EXPECT_THROW(optimizer->tell(f), NonFiniteFitnessError);
  problem->evaluate_batch(batch, f);  // still pending after the rejected tell
  optimizer->tell(f);
  problem->evaluate_batch(optimizer->ask(), f);
  optimizer->tell(f);
  EXPECT_TRUE(optimizer->done());
  EXPECT_THROW(optimizer->ask(), std::logic_error);
}

TEST(AskTell, RunRejectsAProblemWithAnotherBox) {
  const auto problem = make_benchmark("sphere", 3);
  const auto optimizer = make_optimizer("ga", Bounds::unit_box(2), {});
  EXPECT_THROW(run(*optimizer, *problem), std::invalid_argument);
}

// The sphere, except that evaluating the box's upper corner throws: a run started there (its
// initial_positions) fails, random candidates never hit it exactly.
class ThrowsAtTheCorner final : public Problem {
 public:
  explicit ThrowsAtTheCorner(const Problem& inner) : Problem(inner.bounds()), inner_(inner) {}
  void evaluate_batch(std::span<const Eigen::VectorXd> xs, std::span<double> f) const override {
    for (const Eigen::VectorXd& x : xs)
      if (x == bounds().upper) throw std::runtime_error("the corner was evaluated");
    inner_.evaluate_batch(xs, f);
  }

 private:
  const Problem& inner_;
};

TEST(RunTogether, IsolatesAFailedRunAndReportsEachRunInTheRoundItFinishes) {
  // GIVEN four PSO runs in lock-step on a problem that throws on one run's first batch, and
  // budgets of 5, 8, 8 and 3 iterations
  const auto sphere = make_benchmark("sphere", 3, {Parallelism::kOpenMP, 2});
  const ThrowsAtTheCorner problem(*sphere);
  std::vector<RunConfig> configs = {config_with(1, 5), config_with(2, 8), config_with(3, 8),
                                    config_with(4, 3)};
  configs[1].initial_positions = {problem.bounds().upper};
  const auto make_runs = [&](std::vector<std::unique_ptr<Optimizer>>& owners) {
    std::vector<Optimizer*> raw;
    for (const RunConfig& config : configs) {
      owners.push_back(make_optimizer("pso", problem.bounds(), config));
      raw.push_back(owners.back().get());
    }
    return raw;
  };
  std::vector<std::unique_ptr<Optimizer>> owners;
  const std::vector<Optimizer*> runs = make_runs(owners);
  std::vector<std::size_t> finished_order, failed;
  std::string failure;
  TogetherHooks hooks;
  hooks.finished = [&](std::size_t i) {
    ASSERT_TRUE(runs[i]->done());
    finished_order.push_back(i);
    // in the round it finished: the longest run (8 iterations) is exactly as far
    EXPECT_EQ(runs[2]->result().iterations, runs[i]->result().iterations) << "run " << i;
  };
  hooks.failed = [&](std::size_t i, std::exception_ptr error) {
    failed.push_back(i);
    try {
      std::rethrow_exception(error);
    } catch (const std::exception& e) {
      failure = e.what();
    }
  };
  // WHEN they are run together with hooks
  run_together(runs, problem, hooks);
  // THEN only the poisoned run failed, with the problem's error
  EXPECT_EQ(failed, std::vector<std::size_t>{1});
  EXPECT_EQ(failure, "the corner was evaluated");
  // AND every other run was reported once, shortest first, and equals its separate run
  EXPECT_EQ(finished_order, (std::vector<std::size_t>{3, 0, 2}));
  for (std::size_t i : {0, 2, 3}) {
    SCOPED_TRACE("run " + std::to_string(i));
    test::expect_same_run(runs[i]->result(), optimize("pso", *sphere, configs[i]));
  }
  // AND without the failed hook the error propagates
  std::vector<std::unique_ptr<Optimizer>> owners_again;
  EXPECT_THROW(run_together(make_runs(owners_again), problem), std::runtime_error);
}

TEST(RunTogether, RoundHookCountsEveryScoredCandidateOnce) {
  // GIVEN three runs of different lengths (PIO's landmark rounds shrink its batch) advanced
  // together with a round hook
  const auto problem = make_benchmark("sphere", 3);
  std::vector<std::unique_ptr<Optimizer>> owners;
  std::vector<Optimizer*> runs;
  for (const auto& [name, seed, iterations] :
       std::vector<std::tuple<std::string, std::uint64_t, int>>{
           {"pso", 1, 5}, {"pio", 2, 12}, {"ga", 3, 9}}) {
    owners.push_back(make_optimizer(name, problem->bounds(), config_with(seed, iterations)));
    runs.push_back(owners.back().get());
  }
  std::vector<std::size_t> candidates;
  bool all_done_at_last_call = false;
  TogetherHooks hooks;
  hooks.round_done = [&](std::size_t n, std::size_t scored, double scoring_s, double round_s) {
    candidates.push_back(n);
    EXPECT_EQ(scored, n);  // the benchmark problem is not deterministic(): every one is scored
    EXPECT_GE(scoring_s, 0.0);
    EXPECT_GE(round_s, scoring_s);
    all_done_at_last_call =
        std::all_of(runs.begin(), runs.end(), [](const Optimizer* o) { return o->done(); });
  };
  // WHEN they run
  run_together(runs, *problem, hooks);
  // THEN the hook saw every round, the last one after every run had finished
  EXPECT_TRUE(all_done_at_last_call);
  // AND round k scored the k-th batch of every run still going (from the runs' histories)
  std::vector<std::size_t> expected;
  for (const Optimizer* run : runs) {
    const auto& history = run->result().history;
    if (expected.size() < history.size()) expected.resize(history.size(), 0);
    for (std::size_t k = 0; k < history.size(); ++k)
      expected[k] += static_cast<std::size_t>(history[k].batch_size);
  }
  EXPECT_EQ(candidates, expected);
}

TEST(Pio, LandmarkScheduleHalvesThePopulation) {
  // Paper preset: 40 iterations, landmark_fraction 0.25 -> 30 map-and-compass (initial
  // included), then 10 landmark iterations with 5, 3, 2, 2, ... pigeons.
  const auto problem = make_benchmark("sphere", 4);
  const Result result = optimize("pio", *problem, config_with(1, 40));
  ASSERT_EQ(result.history.size(), 40u);
  for (int k = 0; k < 40; ++k) {
    const IterationRecord& record = result.history[k];
    const std::string expected_phase = k == 0 ? "initial" : k < 30 ? "map_compass" : "landmark";
    EXPECT_EQ(record.phase, expected_phase) << k;
    const int expected_size = k < 30 ? 10 : k == 30 ? 5 : k == 31 ? 3 : 2;
    EXPECT_EQ(record.batch_size, expected_size) << k;
  }
  EXPECT_EQ(result.evaluations, 300 + 5 + 3 + 8 * 2);
}

TEST(Pio, MapCompassFollowsEq8And9) {
  // One pigeon, per-dimension rand: V' = V exp(-R Nc) + C r (g - X), X' = X + V'; the move is
  // reproduced with the same random stream.
  const Bounds box = Bounds::unit_box(3);
  Eigen::VectorXd x(3), v(3), g(3);
  x << 0.1, -0.2, 0.3;
  v << 0.05, 0.02, -0.01;
  g << -0.5, 0.4, 0.35;
  Eigen::VectorXd x_expected = x, v_expected = v;
  Rng draws(17);
  for (int j = 0; j < 3; ++j) {
    v_expected[j] = v[j] * std::exp(-0.05 * 4) + 1.0 * draws.uniform() * (g[j] - x[j]);
    x_expected[j] = x[j] + v_expected[j];
  }
  Rng rng(17);
  map_compass_move(box, 0.05, 1.0, 4, true, g, x, v, rng);
  // Not bit-exact: the compiler may contract a * b + c into an FMA differently here.
  for (int j = 0; j < 3; ++j) {
    EXPECT_NEAR(v[j], v_expected[j], 1e-15);
    EXPECT_NEAR(x[j], x_expected[j], 1e-15);
  }
  // Leaving the box: clamped to the face, that velocity component zeroed.
  Eigen::VectorXd x_edge = Eigen::Vector3d(0.95, 0.0, 0.0), v_edge = Eigen::Vector3d(0.5, 0, 0);
  map_compass_move(box, 0.05, 1.0, 1, true, Eigen::Vector3d(0.99, 0, 0), x_edge, v_edge, rng);
  EXPECT_EQ(x_edge[0], 1.0);
  EXPECT_EQ(v_edge[0], 0.0);
}

TEST(EvaluatorOptions, NegativeThreadCountIsRefusedNamingTheValue) {
  EvaluatorOptions options;
  options.parallelism = Parallelism::kOpenMP;
  options.num_threads = -2;
  EXPECT_NE(options.validate().find("num_threads = -2"), std::string::npos) << options.validate();
  const auto sphere = [](const Eigen::VectorXd& x) { return x.squaredNorm(); };
  EXPECT_THROW(FunctionProblem(Bounds::unit_box(2), sphere, options), std::invalid_argument);
  FunctionProblem problem(Bounds::unit_box(2), sphere);
  EXPECT_THROW(problem.set_evaluator(options), std::invalid_argument);
  options.num_threads = 0;
  EXPECT_EQ(options.validate(), "");
  EXPECT_NO_THROW(problem.set_evaluator(options));
}

}  // namespace
}  // namespace insid::opt
