// Standard test functions on the normalised box [-1, 1]^n, shifted so that the optimum is not
// at the centre (swarm methods are biased towards it). Minimum 0 at x = benchmark_optimum(n).
//   sphere:     f = sum_j z_j^2,                                   z = x - o
//   rosenbrock: f = sum_j 100 (z_{j+1} - z_j^2)^2 + (1 - z_j)^2,   z = 2.048 (x - o) + 1
//   rastrigin:  f = 10 n + sum_j z_j^2 - 10 cos(2 pi z_j),         z = 5.12 (x - o)
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "optimizers/problem.h"

namespace insid::opt {

/// o_j = 0.5 sin(1.3 (j + 1)): in [-0.5, 0.5], different in every coordinate.
Eigen::VectorXd benchmark_optimum(int dimension);

double shifted_sphere(const Eigen::VectorXd& x);
double shifted_rosenbrock(const Eigen::VectorXd& x);
double shifted_rastrigin(const Eigen::VectorXd& x);

/// The named function ("sphere", "rosenbrock" or "rastrigin") on [-1, 1]^dimension; throws
/// std::invalid_argument for an unknown name.
std::unique_ptr<FunctionProblem> make_benchmark(std::string_view name, int dimension,
                                                EvaluatorOptions options = {});

}  // namespace insid::opt
