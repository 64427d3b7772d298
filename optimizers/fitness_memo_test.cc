// FitnessMemo and its use by run() and run_together(): a candidate repeated (bit for bit) is
// scored once, and every run is the same as without the memo.
#include "optimizers/fitness_memo.h"

#include <atomic>
#include <cmath>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "optimizers/optimizer.h"
#include "optimizers/registry.h"
#include "test_support/optimizer_runs.h"

namespace insid::opt {
namespace {

// Rastrigin-like fitness that counts the candidates it scores; `deterministic` says whether it
// declares itself deterministic(), so the same function serves as its own memo-less twin.
class CountingProblem final : public Problem {
 public:
  CountingProblem(int dimension, bool deterministic)
      : Problem(Bounds::unit_box(dimension)), deterministic_(deterministic) {}
  void evaluate_batch(std::span<const Eigen::VectorXd> xs, std::span<double> f) const override {
    ++calls;
    for (std::size_t i = 0; i < xs.size(); ++i) {
      ++scored;
      if (xs[i][0] > 0.99)
        throw EvaluationError("counting: candidate " + std::to_string(i) + " is refused");
      double sum = 10.0 * static_cast<double>(xs[i].size());
      for (Eigen::Index j = 0; j < xs[i].size(); ++j) {
        const double y = 4.0 * xs[i][j];
        sum += y * y - 10.0 * std::cos(2.0 * M_PI * y);
      }
      // The sign of a zero shows: 0.0 and -0.0 are different candidates to the memo.
      f[i] = sum + (std::signbit(xs[i][0]) ? 1.0 : 0.0);
    }
  }
  bool deterministic() const override { return deterministic_; }
  std::string name() const override { return deterministic_ ? "counting" : "counting-twin"; }

  mutable std::atomic<long> scored{0}, calls{0};

 private:
  bool deterministic_;
};

Eigen::VectorXd point(double a, double b) { return (Eigen::VectorXd(2) << a, b).finished(); }

RunConfig config_with(std::uint64_t seed, int iterations) {
  RunConfig config;
  config.seed = seed;
  config.max_iterations = iterations;
  config.record_positions = true;
  return config;
}

TEST(FitnessMemo, ScoresEachDistinctCandidateOnceWithTheProblemsValues) {
  // GIVEN a batch with a candidate repeated inside it, and a second batch repeating the first's
  const CountingProblem problem(2, true), twin(2, false);
  FitnessMemo memo;
  const std::vector<Eigen::VectorXd> first = {point(0.1, 0.2), point(0.3, 0.4), point(0.1, 0.2)};
  const std::vector<Eigen::VectorXd> second = {point(0.3, 0.4), point(0.5, 0.6), point(0.1, 0.2),
                                               point(0.5, 0.6)};
  std::vector<double> f1(first.size()), f2(second.size()), direct1(first.size()),
      direct2(second.size());
  // WHEN the memo scores them
  EXPECT_EQ(memo.evaluate_batch(problem, first, f1), 2u);
  EXPECT_EQ(memo.evaluate_batch(problem, second, f2), 1u);
  // THEN each distinct candidate was scored once, in one call per batch
  EXPECT_EQ(problem.scored.load(), 3);
  EXPECT_EQ(problem.calls.load(), 2);
  EXPECT_EQ(memo.size(), 3u);
  // AND every value is the problem's own
  twin.evaluate_batch(first, direct1);
  twin.evaluate_batch(second, direct2);
  EXPECT_EQ(f1, direct1);
  EXPECT_EQ(f2, direct2);
  // AND a batch of known candidates costs no call
  EXPECT_EQ(memo.evaluate_batch(problem, first, f1), 0u);
  EXPECT_EQ(problem.calls.load(), 2);
}

TEST(FitnessMemo, TellsZeroFromMinusZero) {
  const CountingProblem problem(2, true);
  FitnessMemo memo;
  const std::vector<Eigen::VectorXd> xs = {point(0.0, 0.5), point(-0.0, 0.5)};
  std::vector<double> f(2);
  EXPECT_EQ(memo.evaluate_batch(problem, xs, f), 2u);
  EXPECT_EQ(f[1] - f[0], 1.0);
}

TEST(FitnessMemo, MemoryIsBoundedToTwoGenerations) {
  // GIVEN generations of 2 entries WHEN 5 distinct candidates are scored one by one
  const CountingProblem problem(2, true);
  FitnessMemo memo(2);
  std::vector<double> f(1);
  for (int i = 0; i < 5; ++i) {
    const std::vector<Eigen::VectorXd> x = {point(0.1 * i, 0.0)};
    memo.evaluate_batch(problem, x, f);
  }
  // THEN at most 4 are kept: the first is scored again, the last is not
  EXPECT_LE(memo.size(), 4u);
  const long before = problem.scored.load();
  const std::vector<Eigen::VectorXd> last = {point(0.4, 0.0)}, oldest = {point(0.0, 0.0)};
  EXPECT_EQ(memo.evaluate_batch(problem, last, f), 0u);
  EXPECT_EQ(memo.evaluate_batch(problem, oldest, f), 1u);
  EXPECT_EQ(problem.scored.load(), before + 1);
  EXPECT_THROW(FitnessMemo(0), std::invalid_argument);
}

TEST(FitnessMemo, RefusesAProblemThatIsNotDeterministicOrNotItsOwn) {
  const CountingProblem problem(2, true), other(2, true), twin(2, false);
  FitnessMemo memo;
  const std::vector<Eigen::VectorXd> xs = {point(0.1, 0.2)};
  std::vector<double> f(1);
  try {
    memo.evaluate_batch(twin, xs, f);
    ADD_FAILURE() << "a problem that is not deterministic() was accepted";
  } catch (const std::logic_error& e) {
    EXPECT_NE(std::string(e.what()).find("'counting-twin' is not deterministic()"),
              std::string::npos)
        << e.what();
  }
  memo.evaluate_batch(problem, xs, f);
  EXPECT_THROW(memo.evaluate_batch(other, xs, f), std::logic_error);
}

TEST(FitnessMemo, AnErrorNamesTheCandidateByItsPlaceInTheBatch) {
  // GIVEN a memo that knows the first two candidates of a batch whose third is refused
  const CountingProblem problem(2, true);
  FitnessMemo memo;
  std::vector<double> f(2);
  memo.evaluate_batch(problem, std::vector<Eigen::VectorXd>{point(0.1, 0.2), point(0.3, 0.4)}, f);
  const std::vector<Eigen::VectorXd> xs = {point(0.1, 0.2), point(0.3, 0.4), point(1.0, 0.0)};
  std::vector<double> f3(3);
  // WHEN it is scored THEN the error is the problem's for candidate 2 of the batch (not 0 of the
  // unknown ones)
  try {
    memo.evaluate_batch(problem, xs, f3);
    ADD_FAILURE() << "no error";
  } catch (const EvaluationError& e) {
    EXPECT_EQ(std::string(e.what()), "counting: candidate 2 is refused");
  }
  // AND nothing of the failed batch was remembered
  EXPECT_EQ(memo.size(), 2u);
}

TEST(FitnessMemo, RunsTogetherAreTheSameAndRepeatedCandidatesAreScoredOnce) {
  // GIVEN runs that repeat candidates (GA copies, PIO and DVPIO with one seed share their first
  // iterations) on a deterministic problem and on its memo-less twin
  const CountingProblem problem(3, true), twin(3, false);
  const auto make_runs = [](const Problem& p, std::vector<std::unique_ptr<Optimizer>>& owners) {
    std::vector<Optimizer*> runs;
    for (const std::string name : {"ga", "pio", "dvpio", "pso"}) {
      owners.push_back(make_optimizer(name, p.bounds(), config_with(7, 40)));
      runs.push_back(owners.back().get());
    }
    return runs;
  };
  std::vector<std::unique_ptr<Optimizer>> with_memo, without;
  std::size_t asked = 0, scored = 0;
  TogetherHooks hooks;
  hooks.round_done = [&](std::size_t n, std::size_t s, double, double) {
    asked += n;
    scored += s;
  };
  // WHEN each set runs together
  run_together(make_runs(problem, with_memo), problem, hooks);
  const long scored_by_problem = problem.scored.load();
  std::size_t twin_scored = 0;
  hooks.round_done = [&](std::size_t n, std::size_t s, double, double) {
    EXPECT_EQ(s, n);
    twin_scored += s;
  };
  run_together(make_runs(twin, without), twin, hooks);
  // THEN every run is the same, bit for bit
  for (std::size_t i = 0; i < with_memo.size(); ++i)
    test::expect_same_run(with_memo[i]->result(), without[i]->result());
  // AND the problem scored fewer candidates than were asked, as the round hook says
  EXPECT_EQ(twin.scored.load(), static_cast<long>(asked));
  EXPECT_EQ(twin_scored, asked);
  EXPECT_EQ(scored_by_problem, static_cast<long>(scored));
  EXPECT_LT(scored, asked * 9 / 10) << "asked " << asked << ", scored " << scored;
}

TEST(FitnessMemo, AMemoGivenToRunTogetherServesItsLaterCalls) {
  // GIVEN one memo WHEN the same run is made twice through it
  const CountingProblem problem(3, true);
  FitnessMemo memo;
  auto first = make_optimizer("pso", problem.bounds(), config_with(3, 10));
  auto again = make_optimizer("pso", problem.bounds(), config_with(3, 10));
  Optimizer* one[] = {first.get()};
  run_together(one, problem, {}, &memo);
  const long scored = problem.scored.load();
  Optimizer* two[] = {again.get()};
  run_together(two, problem, {}, &memo);
  // THEN the second scored nothing and is the same run
  EXPECT_EQ(problem.scored.load(), scored);
  test::expect_same_run(first->result(), again->result());
}

TEST(FitnessMemo, RunScoresARepeatedCandidateOnceAndGivesTheSameRun) {
  const CountingProblem problem(3, true), twin(3, false);
  auto with_memo = make_optimizer("ga", problem.bounds(), config_with(11, 60));
  auto without = make_optimizer("ga", twin.bounds(), config_with(11, 60));
  const Result& a = run(*with_memo, problem);
  const Result& b = run(*without, twin);
  test::expect_same_run(a, b);
  EXPECT_EQ(twin.scored.load(), b.evaluations);
  EXPECT_LT(problem.scored.load(), twin.scored.load());
}

}  // namespace
}  // namespace insid::opt
