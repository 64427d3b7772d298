// Local polish of an identification: Levenberg-Marquardt on the residual vector (dvE_t, dvN_t)
// with a forward-difference Jacobian through the full mechanization, and an iteratively
// reweighted variant (weights 1/|dv_t|) whose fixed point minimises Eq. 15's sum of norms
// (Weiszfeld-type IRLS). Eq. 15 is a cone on noise-free data (docs/design.md sec. 10), so curvature
// comes from the Gauss-Newton J^T J of the residuals, never from fitness differences.
#pragma once

#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "identification/ins_problem.h"

namespace insid {

struct LocalFitOptions {
  int max_iterations = 30;        ///< LM iterations (each: 1 + n residual runs)
  double step_sigma = 1e-3;       ///< finite-difference step, sigma units
  double tolerance_sigma = 1e-6;  ///< stop when the step is below this (sigma units)
  bool eq15 = true;               ///< IRLS towards the Eq. 15 optimum (else least squares)
  bool clamp_to_box = true;       ///< keep the estimate inside the search box
  /// Fill LocalFitResult::jacobian_sigma (m x n doubles: 55 MB for paper-fig9's 1.7 M
  /// residuals); the reference optimum, which needs only the estimate, leaves it empty.
  bool keep_jacobian = true;

  /// "" when valid, else why, naming the value: max_iterations >= 0, step_sigma a positive
  /// finite number, tolerance_sigma a non-negative finite number. local_fit checks it first.
  std::string validate() const;
};

struct LocalFitResult {
  Eigen::VectorXd x;             ///< normalised coordinates
  Eigen::VectorXd value_sigma;   ///< sigma units
  double fitness = 0.0;          ///< Eq. 15 at x
  double sum_squares = 0.0;      ///< sum of squared residuals at x
  std::int64_t evaluations = 0;  ///< full INS runs spent (Jacobian columns included)
  int iterations = 0;
  /// d r / d value_sigma (m/s per sigma): the last forward-difference Jacobian, taken at the
  /// point before the last step (at x when that step was rejected); empty when max_iterations is
  /// 0 or without LocalFitOptions::keep_jacobian.
  Eigen::MatrixXd jacobian_sigma;
  std::vector<double> residuals;  ///< at x
};

/// Polishes from x0 (normalised coordinates) on the problem's residual vector.
LocalFitResult local_fit(const InsIdentificationProblem& problem, const Eigen::VectorXd& x0,
                         const LocalFitOptions& options = {});

/// Polishes from each of `x0s` at once, in lock-step: each round scores what every unfinished
/// start waits for (its start point, its n Jacobian columns or a trial point) as one batch, so
/// the batched kernel fills its SIMD vectors across starts (the starts of the reference optimum
/// ran as four one-vector passes before). Result i equals local_fit(problem, x0s[i], options)
/// bit for bit: a candidate's residuals do not depend on the batch it is scored in. The starts'
/// own linear algebra runs on up to `threads` threads; the scoring uses the problem's own.
std::vector<LocalFitResult> local_fits(const InsIdentificationProblem& problem,
                                       std::span<const Eigen::VectorXd> x0s,
                                       const LocalFitOptions& options = {}, int threads = 1);

}  // namespace insid
