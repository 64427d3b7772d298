#include "optimizers/problem.h"

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "optimizers/random.h"

namespace insid::opt {
namespace {

std::vector<Eigen::VectorXd> random_points(int count, int dimension, std::uint64_t seed) {
  Rng rng(seed);
  std::vector<Eigen::VectorXd> points(count, Eigen::VectorXd::Zero(dimension));
  for (Eigen::VectorXd& x : points) {
    for (int j = 0; j < dimension; ++j) x[j] = rng.uniform(-1.0, 1.0);
  }
  return points;
}

double bumpy(const Eigen::VectorXd& x) {
  double f = 0.0;
  for (Eigen::Index j = 0; j < x.size(); ++j) f += std::sin(3.0 * x[j]) + x[j] * x[j];
  return f;
}

TEST(Rng, UniformIsInUnitIntervalAndSeeded) {
  Rng a(7), b(7), c(8);
  bool differs = false;
  for (int k = 0; k < 1000; ++k) {
    const double u = a.uniform();
    EXPECT_GE(u, 0.0);
    EXPECT_LT(u, 1.0);
    EXPECT_EQ(u, b.uniform());
    differs = differs || u != c.uniform();
  }
  EXPECT_TRUE(differs);
}

TEST(Rng, BelowCoversRangeWithoutBias) {
  Rng rng(3);
  std::vector<int> counts(5, 0);
  for (int k = 0; k < 50000; ++k) ++counts[rng.below(5)];
  for (int c : counts) EXPECT_NEAR(c, 10000, 500);  // ~5 sigma
}

TEST(Bounds, ValidatesShapeAndOrder) {
  EXPECT_EQ(Bounds::unit_box(3).validate(), "");
  Bounds inverted{Eigen::Vector2d(0.0, 1.0), Eigen::Vector2d(1.0, 1.0)};
  EXPECT_NE(inverted.validate().find("dimension 1"), std::string::npos) << inverted.validate();
  Bounds mismatched{Eigen::VectorXd::Zero(2), Eigen::VectorXd::Ones(3)};
  EXPECT_FALSE(mismatched.validate().empty());
  EXPECT_THROW(FunctionProblem(Bounds{}, bumpy), std::invalid_argument);
}

TEST(Evaluator, SerialAndOpenMPGiveIdenticalValues) {
  const auto points = random_points(257, 6, 11);
  std::vector<double> serial(points.size()), one(points.size()), two(points.size());
  evaluate_each(points, serial, {Parallelism::kSerial, 0}, bumpy);
  evaluate_each(points, one, {Parallelism::kOpenMP, 1}, bumpy);
  evaluate_each(points, two, {Parallelism::kOpenMP, 2}, bumpy);
  for (std::size_t i = 0; i < points.size(); ++i) EXPECT_EQ(serial[i], bumpy(points[i]));
  EXPECT_EQ(serial, one);
  EXPECT_EQ(serial, two);
}

TEST(Evaluator, ExceptionInParallelRegionIsPropagatedWithCandidate) {
  // GIVEN a fitness that throws for two candidates, WHEN evaluated on 2 threads, THEN the
  // lowest failing index is reported, with the original exception nested.
  const auto points = random_points(64, 3, 5);
  const FunctionProblem problem(Bounds::unit_box(3),
                                [&](const Eigen::VectorXd& x) {
                                  if (&x == &points[17] || &x == &points[40])
                                    throw std::domain_error("kernel diverged");
                                  return bumpy(x);
                                },
                                {Parallelism::kOpenMP, 2});
  std::vector<double> f(points.size());
  try {
    problem.evaluate_batch(points, f);
    FAIL() << "no exception";
  } catch (const EvaluationError& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("candidate 17 at x = ["), std::string::npos) << message;
    EXPECT_NE(message.find("kernel diverged"), std::string::npos) << message;
    EXPECT_THROW(std::rethrow_if_nested(e), std::domain_error);
  }
}

TEST(Evaluator, ExceptionInSerialEvaluationNamesCandidate) {
  const auto points = random_points(4, 2, 5);
  const FunctionProblem problem(Bounds::unit_box(2), [](const Eigen::VectorXd&) -> double {
    throw 42;  // not a std::exception
  });
  std::vector<double> f(points.size());
  try {
    problem.evaluate_batch(points, f);
    FAIL() << "no exception";
  } catch (const EvaluationError& e) {
    EXPECT_NE(std::string(e.what()).find("candidate 0"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("unknown exception"), std::string::npos) << e.what();
  }
}

TEST(Evaluator, RejectsOutputOfWrongSize) {
  const auto points = random_points(4, 2, 5);
  std::vector<double> f(3);
  EXPECT_THROW(evaluate_each(points, f, {}, bumpy), std::invalid_argument);
}

TEST(CheckFiniteFitness, NamesCandidateIndexAndCoordinates) {
  std::vector<Eigen::VectorXd> xs = {Eigen::Vector2d(0.5, -0.25), Eigen::Vector2d(0.125, 1.0)};
  std::vector<double> f = {1.0, std::numeric_limits<double>::quiet_NaN()};
  try {
    check_finite_fitness(xs, f, "test");
    FAIL() << "no exception";
  } catch (const NonFiniteFitnessError& e) {
    EXPECT_STREQ(e.what(), "test: non-finite fitness nan for candidate 1 at x = [0.125, 1]");
  }
  f[1] = std::numeric_limits<double>::infinity();
  EXPECT_THROW(check_finite_fitness(xs, f, "test"), NonFiniteFitnessError);
  f[1] = 2.0;
  EXPECT_NO_THROW(check_finite_fitness(xs, f, "test"));
}

}  // namespace
}  // namespace insid::opt
