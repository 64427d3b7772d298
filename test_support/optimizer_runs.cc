#include "test_support/optimizer_runs.h"

#include <string>

#include <gtest/gtest.h>

namespace insid::test {

bool same(const Eigen::VectorXd& a, const Eigen::VectorXd& b) {
  return a.size() == b.size() && (a.size() == 0 || a == b);
}
bool same(const std::vector<Eigen::VectorXd>& a, const std::vector<Eigen::VectorXd>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (!same(a[i], b[i])) return false;
  }
  return true;
}

void expect_same_run(const opt::Result& a, const opt::Result& b) {
  EXPECT_EQ(a.algorithm, b.algorithm);
  EXPECT_EQ(a.parameters, b.parameters);
  EXPECT_EQ(a.seed, b.seed);
  EXPECT_TRUE(same(a.best_x, b.best_x));
  EXPECT_EQ(a.best_f, b.best_f);
  EXPECT_EQ(a.evaluations, b.evaluations);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.termination, b.termination);
  EXPECT_EQ(a.best_per_evaluation, b.best_per_evaluation);
  ASSERT_EQ(a.history.size(), b.history.size());
  for (std::size_t k = 0; k < a.history.size(); ++k) {
    SCOPED_TRACE("iteration " + std::to_string(k + 1));
    const opt::IterationRecord& x = a.history[k];
    const opt::IterationRecord& y = b.history[k];
    EXPECT_EQ(x.iteration, y.iteration);
    EXPECT_EQ(x.evaluations, y.evaluations);
    EXPECT_EQ(x.batch_size, y.batch_size);
    EXPECT_EQ(x.best_fitness, y.best_fitness);
    EXPECT_EQ(x.median_fitness, y.median_fitness);
    EXPECT_EQ(x.diversity, y.diversity);
    EXPECT_EQ(x.phase, y.phase);
    EXPECT_EQ(x.premature, y.premature);
    EXPECT_TRUE(same(x.d_positive, y.d_positive));
    EXPECT_TRUE(same(x.d_negative, y.d_negative));
    EXPECT_EQ(x.direction_flags, y.direction_flags);
    EXPECT_TRUE(same(x.positions, y.positions));
    EXPECT_EQ(x.fitness, y.fitness);
  }
}

}  // namespace insid::test
