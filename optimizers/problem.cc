#include "optimizers/problem.h"

#include <cmath>
#include <exception>
#include <utility>

#include <omp.h>

#include "base/threads.h"
#include "optimizers/parameters.h"

namespace insid::opt {

Bounds Bounds::unit_box(int dimension) {
  return {Eigen::VectorXd::Constant(dimension, -1.0), Eigen::VectorXd::Constant(dimension, 1.0)};
}

std::string Bounds::validate() const {
  if (lower.size() < 1)
    return "bounds: dimension must be >= 1, got " + std::to_string(lower.size());
  if (lower.size() != upper.size()) {
    return "bounds: lower has " + std::to_string(lower.size()) + " entries, upper has " +
           std::to_string(upper.size());
  }
  for (Eigen::Index j = 0; j < lower.size(); ++j) {
    if (!std::isfinite(lower[j]) || !std::isfinite(upper[j]) || !(lower[j] < upper[j])) {
      return "bounds: dimension " + std::to_string(j) + " needs finite lower < upper, got [" +
             format_number(lower[j]) + ", " + format_number(upper[j]) + "]";
    }
  }
  return {};
}

bool Bounds::contains(const Eigen::VectorXd& x) const {
  return x.size() == lower.size() && (x.array() >= lower.array()).all() &&
         (x.array() <= upper.array()).all();
}

void check_finite_fitness(std::span<const Eigen::VectorXd> xs, std::span<const double> f,
                          const std::string& context) {
  for (std::size_t i = 0; i < f.size(); ++i) {
    if (std::isfinite(f[i])) continue;
    throw NonFiniteFitnessError(context + ": non-finite fitness " + format_number(f[i]) +
                                " for candidate " + std::to_string(i) +
                                " at x = " + format_vector(xs[i]));
  }
}

Problem::Problem(Bounds bounds) : bounds_(std::move(bounds)) {
  if (const std::string error = bounds_.validate(); !error.empty()) {
    throw std::invalid_argument(error);
  }
}

namespace {

// Rethrows `error` (caught while scoring candidate `index`) as an EvaluationError that names
// the candidate, with the original exception nested.
[[noreturn]] void rethrow_for_candidate(const std::exception_ptr& error, std::size_t index,
                                        const Eigen::VectorXd& x) {
  const std::string where = "fitness evaluation failed for candidate " + std::to_string(index) +
                            " at x = " + format_vector(x) + ": ";
  try {
    std::rethrow_exception(error);
  } catch (const std::exception& e) {
    std::throw_with_nested(EvaluationError(where + e.what()));
  } catch (...) {
    std::throw_with_nested(EvaluationError(where + "unknown exception"));
  }
}

}  // namespace

void evaluate_each(std::span<const Eigen::VectorXd> xs, std::span<double> f_out,
                   const EvaluatorOptions& options,
                   const std::function<double(const Eigen::VectorXd&)>& fitness) {
  if (f_out.size() != xs.size()) {
    throw std::invalid_argument("evaluate_each: " + std::to_string(xs.size()) + " candidates but " +
                                std::to_string(f_out.size()) + " output slots");
  }
  const auto count = static_cast<std::ptrdiff_t>(xs.size());
  if (options.parallelism == Parallelism::kSerial) {
    for (std::ptrdiff_t i = 0; i < count; ++i) {
      try {
        f_out[i] = fitness(xs[i]);
      } catch (...) {
        rethrow_for_candidate(std::current_exception(), static_cast<std::size_t>(i), xs[i]);
      }
    }
    return;
  }

  // One slot per candidate: no synchronisation, and the rethrown error is the lowest index
  // whatever the thread count or schedule.
  std::vector<std::exception_ptr> errors(xs.size());
  const int threads = options.threads();
#pragma omp parallel for schedule(dynamic, 1) num_threads(threads)
  for (std::ptrdiff_t i = 0; i < count; ++i) {
    try {
      f_out[i] = fitness(xs[i]);
    } catch (...) {
      errors[i] = std::current_exception();
    }
  }
  for (std::size_t i = 0; i < errors.size(); ++i) {
    if (errors[i]) rethrow_for_candidate(errors[i], i, xs[i]);
  }
}

std::string EvaluatorOptions::validate() const {
  if (num_threads < 0)
    return "EvaluatorOptions: num_threads = " + std::to_string(num_threads) +
           " (expected 0 for the OpenMP default, or a positive count)";
  return "";
}

const EvaluatorOptions& EvaluatorOptions::validated() const {
  if (const std::string why = validate(); !why.empty()) throw std::invalid_argument(why);
  return *this;
}

int EvaluatorOptions::threads() const {
  if (parallelism != Parallelism::kOpenMP) return 1;
  return insid::thread_count(num_threads);
}

ScalarProblem::ScalarProblem(Bounds bounds, EvaluatorOptions options)
    : Problem(std::move(bounds)), options_(options.validated()) {}

void ScalarProblem::evaluate_batch(std::span<const Eigen::VectorXd> xs,
                                   std::span<double> f_out) const {
  evaluate_each(xs, f_out, options_, [this](const Eigen::VectorXd& x) { return fitness(x); });
}

FunctionProblem::FunctionProblem(Bounds bounds, Function function, EvaluatorOptions options,
                                 std::string name)
    : ScalarProblem(std::move(bounds), options),
      function_(std::move(function)),
      name_(std::move(name)) {
  if (!function_) throw std::invalid_argument("FunctionProblem: empty function");
}

}  // namespace insid::opt
