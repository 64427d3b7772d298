#include "optimizers/test_functions.h"

#include <cmath>
#include <numbers>
#include <stdexcept>

namespace insid::opt {

namespace {
double optimum_coordinate(Eigen::Index j) {
  return 0.5 * std::sin(1.3 * static_cast<double>(j + 1));
}
}  // namespace

Eigen::VectorXd benchmark_optimum(int dimension) {
  Eigen::VectorXd o(dimension);
  for (int j = 0; j < dimension; ++j) o[j] = optimum_coordinate(j);
  return o;
}

double shifted_sphere(const Eigen::VectorXd& x) {
  double f = 0.0;
  for (Eigen::Index j = 0; j < x.size(); ++j) {
    const double z = x[j] - optimum_coordinate(j);
    f += z * z;
  }
  return f;
}

double shifted_rosenbrock(const Eigen::VectorXd& x) {
  double f = 0.0;
  for (Eigen::Index j = 0; j + 1 < x.size(); ++j) {
    const double z = 2.048 * (x[j] - optimum_coordinate(j)) + 1.0;
    const double z_next = 2.048 * (x[j + 1] - optimum_coordinate(j + 1)) + 1.0;
    f += 100.0 * (z_next - z * z) * (z_next - z * z) + (1.0 - z) * (1.0 - z);
  }
  return f;
}

double shifted_rastrigin(const Eigen::VectorXd& x) {
  double f = 10.0 * static_cast<double>(x.size());
  for (Eigen::Index j = 0; j < x.size(); ++j) {
    const double z = 5.12 * (x[j] - optimum_coordinate(j));
    f += z * z - 10.0 * std::cos(2.0 * std::numbers::pi * z);
  }
  return f;
}

std::unique_ptr<FunctionProblem> make_benchmark(std::string_view name, int dimension,
                                                EvaluatorOptions options) {
  FunctionProblem::Function function;
  if (name == "sphere") {
    function = shifted_sphere;
  } else if (name == "rosenbrock") {
    function = shifted_rosenbrock;
  } else if (name == "rastrigin") {
    function = shifted_rastrigin;
  } else {
    throw std::invalid_argument("unknown benchmark '" + std::string(name) +
                                "'; valid: sphere, rosenbrock, rastrigin");
  }
  return std::make_unique<FunctionProblem>(Bounds::unit_box(dimension), std::move(function),
                                           options, std::string(name));
}

}  // namespace insid::opt
