// Each optimizer on the shifted sphere, Rosenbrock and Rastrigin functions (test_functions.h)
// in 4 and 10 dimensions, default (paper Table 4) parameters, 20 seeds (1000..1019). Budget:
// 2000 evaluations in 4-D, 10000 in 10-D. A case passes when at least `min_successes` of the
// 20 runs end with best fitness <= `threshold`. Thresholds are what the algorithms reach
// (README.md lists the measured success counts); min_successes leaves a margin of about 15 %
// for other compilers and maths libraries.
//
// An absolute threshold alone can be passed by chance: each case also runs uniform random
// search with the same budget and seeds, and the algorithm's median final fitness must beat
// random search's median by `beats_random_by` (a factor; stated per case from measured
// ratios with a margin, README.md).
#include <algorithm>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "optimizers/random.h"
#include "optimizers/registry.h"
#include "optimizers/test_functions.h"

namespace insid::opt {
namespace {

struct Case {
  std::string algorithm;
  std::string function;
  int dimension;
  double threshold;
  int min_successes;             // of 20
  double beats_random_by;        // median(random search) / median(algorithm) must reach this
  ParameterMap parameters = {};  // overrides of the defaults (a variant)
};

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 == 1 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Best of `evaluations` points drawn uniformly in the problem's box (the chance baseline).
double random_search(const ScalarProblem& problem, int evaluations, std::uint64_t seed) {
  Rng rng(seed);
  const Bounds& box = problem.bounds();
  Eigen::VectorXd x(box.dimension());
  double best = std::numeric_limits<double>::infinity();
  for (int k = 0; k < evaluations; ++k) {
    for (int i = 0; i < x.size(); ++i) x[i] = rng.uniform(box.lower[i], box.upper[i]);
    best = std::min(best, problem.fitness(x));
  }
  return best;
}

std::string case_name(const Case& c) {
  std::string name = c.algorithm + "_" + c.function + "_" + std::to_string(c.dimension) + "d";
  for (const auto& [key, value] : c.parameters) name += "_" + key;  // variants: flag names
  return name;
}

class Convergence : public ::testing::TestWithParam<Case> {};

TEST_P(Convergence, ReachesThresholdInStatedShareOfSeeds) {
  const Case& c = GetParam();
  const auto problem = make_benchmark(c.function, c.dimension);
  int successes = 0;
  double worst = 0.0;
  std::vector<double> finals, chance;
  for (std::uint64_t seed = 1000; seed < 1020; ++seed) {
    RunConfig config;
    config.seed = seed;
    config.max_iterations = 0;
    config.max_evaluations = c.dimension == 4 ? 2000 : 10000;
    const Result result = optimize(c.algorithm, *problem, config, c.parameters);
    ASSERT_EQ(result.evaluations, config.max_evaluations);
    successes += result.best_f <= c.threshold;
    worst = std::max(worst, result.best_f);
    finals.push_back(result.best_f);
    chance.push_back(random_search(*problem, config.max_evaluations, seed));
  }
  const double ratio = median(chance) / median(finals);
  std::printf(
      "[ measured ] %-26s f <= %-7g in %2d/20 runs (required %d), worst %.3g; median "
      "%.3g vs random search %.3g (%.3gx, required %gx)\n",
      case_name(c).c_str(), c.threshold, successes, c.min_successes, worst, median(finals),
      median(chance), ratio, c.beats_random_by);
  EXPECT_GE(successes, c.min_successes) << "threshold " << c.threshold;
  EXPECT_GE(ratio, c.beats_random_by)
      << "median " << median(finals) << " vs random search " << median(chance);
}

INSTANTIATE_TEST_SUITE_P(
    Benchmarks, Convergence,
    ::testing::Values(
        // 4-D, 2000 evaluations. Not here: PIO and DVPIO on Rastrigin, whose medians (11.0,
        // 10.9) do not beat random search's (11.3) at this budget (optimizers/README.md).
        Case{"ga", "sphere", 4, 1e-4, 17, 1000}, Case{"pso", "sphere", 4, 1e-3, 17, 1000},
        Case{"pio", "sphere", 4, 1e-2, 16, 100}, Case{"dvpio", "sphere", 4, 1e-10, 17, 1e9},
        Case{"ga", "rosenbrock", 4, 5.0, 17, 2.5}, Case{"pso", "rosenbrock", 4, 5.0, 17, 4},
        Case{"pio", "rosenbrock", 4, 5.0, 13, 1.2}, Case{"dvpio", "rosenbrock", 4, 5.0, 16, 3},
        Case{"ga", "rastrigin", 4, 5.0, 17, 5}, Case{"pso", "rastrigin", 4, 10.0, 16, 2.5},
        // 10-D, 10000 evaluations. Not here: PIO on Rastrigin (median 62.5 vs random 74.3).
        Case{"ga", "sphere", 10, 2e-4, 17, 1000}, Case{"pso", "sphere", 10, 2e-3, 17, 300},
        Case{"pio", "sphere", 10, 1.0, 17, 2}, Case{"dvpio", "sphere", 10, 0.1, 17, 1e9},
        Case{"ga", "rosenbrock", 10, 10.0, 17, 20}, Case{"pso", "rosenbrock", 10, 20.0, 16, 15},
        Case{"pio", "rosenbrock", 10, 500.0, 17, 1.5},
        Case{"dvpio", "rosenbrock", 10, 150.0, 16, 20}, Case{"ga", "rastrigin", 10, 10.0, 16, 10},
        Case{"pso", "rastrigin", 10, 30.0, 16, 3}, Case{"dvpio", "rastrigin", 10, 80.0, 17, 1.3},
        // DVPIO's shrink_without_gain variant (not the paper's Eq. 14), 10-D.
        Case{"dvpio", "sphere", 10, 1e-10, 17, 1e9, {{"shrink_without_gain", 1}}},
        Case{"dvpio", "rosenbrock", 10, 100.0, 17, 20, {{"shrink_without_gain", 1}}},
        Case{"dvpio", "rastrigin", 10, 80.0, 17, 1.3, {{"shrink_without_gain", 1}}}),
    [](const auto& param_info) { return case_name(param_info.param); });

}  // namespace
}  // namespace insid::opt
